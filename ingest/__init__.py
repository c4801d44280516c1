"""trebuchet.ingest"""
