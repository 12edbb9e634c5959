"""Test data shared by the core tests: small, deterministic impact profiles."""

import numpy as np

VELOCITIES = (2.42, 2.80, 3.13, 3.43, 3.70, 3.96)


def tiny_profiles(velocities, n=500, rate=1000.0):
    """Damped sinusoids whose frequency, decay and onset change with velocity."""
    t = np.arange(n) / rate
    rows = []
    for v in velocities:
        onset = 0.02 + 0.01 * (5.3 - v)
        tt = np.clip(t - onset, 0, None)
        rows.append(v * np.exp(-tt * (20 + 4 * v)) * np.sin(2 * np.pi * (40 + 12 * v) * tt) * (t >= onset))
    return np.array(rows)


def fake_distribution(site, *, dist: str, version: str, entry_point: str, module: str, source: str):
    """Put a real (metadata-only) distribution on ``site``: a module plus a .dist-info whose
    entry point in group ``hapticfx`` names it, as pip would install it."""
    import textwrap

    (site / f"{module}.py").write_text(textwrap.dedent(source))
    info = site / f"{module}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(f"[hapticfx]\n{entry_point} = {module}\n")


def actuator_plugin(cls: str, name: str) -> str:
    """The source of a plugin module that registers one actuator, ``name``: a memory actuator of class ``cls``."""
    return f'''
        from hapticfx.hookspecs import hookimpl
        from hapticfx.actuators.virtual import MemoryActuator

        class {cls}(MemoryActuator):
            """A third-party actuator."""
            name = "{name}"

        @hookimpl
        def register_actuators(register):
            register("{name}", {cls})
    '''
