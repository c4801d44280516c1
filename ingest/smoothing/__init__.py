"""The smoother: noise tuning, motion-model choice, trigger and release scan, band calibration."""
