"""Evaluation: the validity judge, the benchmark runner, tables and plots (issue 3)."""
