"""The command line (the top layer: it imports the rest of the toolkit, nothing imports it)."""
from .main import main

__all__ = ["main"]
