"""The impact surface: impact map, singularity set, basins and (1,n) response curves."""
