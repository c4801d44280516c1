"""Sample scenes and angle logs shipped with trebuchet (logs are synthetic: see README)."""
