"""Baselines of the paper (section 4.2): Naive (ICP of the object) and BS (ICP of the bisector)."""
