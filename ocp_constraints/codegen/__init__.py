"""C code export of a model's constraint functions, compiled and checked (uses mechanics)."""
