"""trebuchet.fmu"""
