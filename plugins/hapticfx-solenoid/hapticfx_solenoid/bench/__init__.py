"""The solenoid's measurements: the command round trip through a pseudo-terminal (``roundtrip``) and
``hapticfx bench isolation`` (``isolation``).

Measurement only: the actuator and its serial link never import it (tests/test_import_graph.py).
"""
