"""Format readers: one module per tracking tool, and the table, unit, time and name helpers
they share. Nothing here knows the engine.
"""
