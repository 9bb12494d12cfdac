"""Scoring and showing results: a run's evaluation against ground truth, its plots, and the HTML report."""
