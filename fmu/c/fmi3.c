/* FMI 3.0 layer: not yet written. */
