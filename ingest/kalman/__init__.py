"""The Kalman filter and smoother for polynomial motion models: batch filter, compiled kernel,
filterpy reference. Nothing here is trebuchet-specific.
"""
