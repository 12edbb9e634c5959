"""``hapticfx bench table`` (a velocity table against its network) and ``hapticfx bench threads`` (torch threads).

Measurement only: the interpolators and training never import it (tests/test_import_graph.py).
"""
