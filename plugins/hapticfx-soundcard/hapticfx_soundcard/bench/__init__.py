"""``hapticfx bench output`` and the probes it runs: the capture of the null sink's monitor (``output``), the
machine's own stalls (``stallprobe``), an embedding program whose sound server fails (``faultprobe``) and a
private PulseAudio server to fail (``virtualserver``).

Measurement only: the actuator, mixer and streams never import it (tests/test_import_graph.py).
"""
