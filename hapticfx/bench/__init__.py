"""What ``hapticfx bench`` measures in the core: render time, start-up, interpolators, reducers, parallel simulation, the contact
integration, the network bridge, floods and hostile input.

Measurement only. No module that plays an impact imports this package (tests/test_import_graph.py); the
command groups' wiring (``builtins/``, ``commands.py``) imports it inside the bench commands.
"""
