"""The impact surface: the impact map and its Jacobian, the singularity set, domains of
attraction and the (1,n) response curves (Budd & Dux's objects, on this package's engines).

Reference: C. Budd, F. Dux, "Chattering and related behaviour in impact oscillators",
Phil. Trans. R. Soc. A 347 (1994) 365-389; "Intermittency in impact oscillators close to
resonance", Nonlinearity 7 (1994) 1191-1224.
"""
