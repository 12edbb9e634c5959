"""hapticfx-neural: the paper's ConvBiLSTM encoder-decoder interpolator, its baselines, training and benchmark.

Importing this package (or its registration module :mod:`hapticfx_neural.plugin`)
does not import torch; torch is imported when a network is built or trained.
"""

__version__ = "0.1.0"
