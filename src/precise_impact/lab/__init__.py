"""What users bring from the bench: netlists, raw files, captures, tolerance budgets."""
