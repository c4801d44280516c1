"""A log as the package reads it: format recognised, checked, repaired, angles from points."""
