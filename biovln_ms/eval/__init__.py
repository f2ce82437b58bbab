"""Evaluation: the harness, aggregate metrics with confidence intervals, McNemar tests, reports."""
