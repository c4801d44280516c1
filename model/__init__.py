"""trebuchet.model"""
