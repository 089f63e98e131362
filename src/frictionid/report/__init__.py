"""Presentation of results: text tables, plots, reports."""
