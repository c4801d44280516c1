"""Figures and HTML reports, above both the model and the ingest path."""
