"""Fuzzing the input gates and the safety limiter (``hapticfx bench fuzz``): mutants of valid inputs
(``mutate``: bytes; ``confuse``: values of the wrong type in the YAML formats), the gates that take them (``gates``), the runner that classifies what came back
(``runner``), and random overrides through shaping and the limiter checked the hard way (``limits``)."""
