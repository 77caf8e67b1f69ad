"""oftimg: beating tubes to images and numbers."""
__version__ = "0.1.0"
