"""The impact surface: impact map, singularity set, domains of attraction, (1,n) curves."""
