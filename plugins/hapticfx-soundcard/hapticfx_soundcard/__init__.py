"""Sound-card actuators for hapticfx: a vibro-transducer and a haptuator behind an amplifier.

Importing this package does not import sounddevice; the PortAudio library is
loaded when an actuator opens its device or ``hapticfx devices`` runs.
"""
