"""Impact datasets: the on-disk format, CSV import, profile banks built from them, and the ``data`` commands."""
