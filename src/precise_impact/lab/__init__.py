"""What users bring from the bench: netlists, raw files, scope captures, tolerance budgets."""
