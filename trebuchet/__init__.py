"""trebuchet: internal forces of the swinging-counterweight trebuchet."""
