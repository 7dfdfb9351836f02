"""The impact surface: the impact map, its singularity set and their plots."""
