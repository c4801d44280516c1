"""Identification of an engine from its filmed shot: the engine's own equations of motion fitted
to the log's angles (:func:`~trebuchet.ingest.identification.identify.identify`), and the
loads taken from the fitted engine (:mod:`~trebuchet.ingest.identification.fitted_loads`)."""
