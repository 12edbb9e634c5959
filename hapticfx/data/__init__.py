"""Datasets of impact recordings, their preprocessing, and the profile banks built from them."""
