"""The shot's events in a log: trigger and release search, lift-off, the release from the
engine's equations.
"""
