"""The torch networks: the paper's ConvBiLSTM encoder-decoder and the Table 3 baselines.

Every network maps ``x (B, T, 2, S)`` - the lower and upper neighbour profiles
cut into ``T`` recurrent steps of ``S`` samples - and ``vel (B, 2)`` - the
velocity features - to a correction ``(B, T, S)`` of the linear blend of the two
neighbours' centres (:func:`blend_plus_correction`). The velocity enters only the final
fully connected layer, concatenated to each step's decoder output (paper Sect. 4.2).
That layer starts at zero, so an untrained network is the blend of the neighbours' centres.
"""

from __future__ import annotations

import torch
from torch import nn


class ConvLSTMLayer(nn.Module):
    """One ConvLSTM layer (paper Eqs. 1-7), optionally bidirectional.

    Input and state at each step are 1D maps of ``S`` samples; ``W*x`` and ``R*h``
    are 1D convolutions (kernel ``k``), ``U∘c`` are peephole (Hadamard) terms.
    Both directions run in one loop through grouped convolutions.
    """

    def __init__(self, in_channels: int, filters: int, width: int, *, kernel: int = 3, bidirectional: bool = True):
        super().__init__()
        self.d = 2 if bidirectional else 1
        self.filters = filters
        pad = kernel // 2
        self.w = nn.Conv1d(self.d * in_channels, self.d * 4 * filters, kernel, padding=pad, groups=self.d)
        self.r = nn.Conv1d(self.d * filters, self.d * 4 * filters, kernel, padding=pad, groups=self.d, bias=False)
        self.u = nn.Parameter(torch.zeros(self.d, 3, filters, width))

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``x (B, T, C, S)`` -> all outputs ``(B, T, d*F, S)`` and the final state ``(B, d*F, S)``."""
        b, t, c, s = x.shape
        d, f = self.d, self.filters
        xs = torch.cat([x, x.flip(1)], dim=2) if d == 2 else x
        wx = self.w(xs.reshape(b * t, d * c, s)).reshape(b, t, d, 4 * f, s)
        h = x.new_zeros(b, d, f, s)
        cell = x.new_zeros(b, d, f, s)
        outs = []
        for wx_step in wx.unbind(1):  # not wx[:, step]: each index's gradient would be a zero-filled copy of wx
            g = wx_step + self.r(h.reshape(b, d * f, s)).reshape(b, d, 4 * f, s)
            gi, gf, gc, go = g.split(f, dim=2)
            i = torch.sigmoid(gi + self.u[:, 0] * cell)
            fg = torch.sigmoid(gf + self.u[:, 1] * cell)
            cell = fg * cell + i * torch.tanh(gc)
            o = torch.sigmoid(go + self.u[:, 2] * cell)
            h = o * torch.tanh(cell)
            outs.append(h)
        out = torch.stack(outs, dim=1)  # (B, T, d, F, S); direction 1 runs backwards in time
        if d == 2:
            out = torch.cat([out[:, :, :1], out[:, :, 1:].flip(1)], dim=2)
        return out.reshape(b, t, d * f, s), h.reshape(b, d * f, s)


class LSTMStack(nn.Module):
    """Stacked (Bi)LSTM layers of different sizes with dropout after each layer."""

    def __init__(self, in_features: int, sizes: list[int], *, bidirectional: bool, dropout: float):
        super().__init__()
        d = 2 if bidirectional else 1
        layers, n_in = [], in_features
        for size in sizes:
            layers.append(nn.LSTM(n_in, size, batch_first=True, bidirectional=bidirectional))
            n_in = d * size
        self.layers = nn.ModuleList(layers)
        self.drop = nn.Dropout(dropout)
        self.out_features = n_in
        self.d = d

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``x (B, T, F)`` -> outputs ``(B, T, out)`` and the final summary vector ``(B, out)``."""
        for layer in self.layers:
            x, (h, _) = layer(x)
            x = self.drop(x)
        # h: (d, B, H) final states: forward at t=T-1, backward at t=0
        return x, self.drop(h.transpose(0, 1).reshape(x.shape[0], -1))


class SequenceRegressor(nn.Module):
    """(Bi)LSTM over the neighbour steps, then a per-step dense layer (Table 3 `lstm`, `bilstm`)."""

    def __init__(self, width: int, *, sizes: list[int], bidirectional: bool, dropout: float):
        super().__init__()
        self.rnn = LSTMStack(2 * width, sizes, bidirectional=bidirectional, dropout=dropout)
        self.fc = nn.Linear(self.rnn.out_features + 2, width)

    def forward(self, x: torch.Tensor, vel: torch.Tensor) -> torch.Tensor:
        b, t, _, s = x.shape
        h, _ = self.rnn(x.reshape(b, t, 2 * s))
        return self.fc(torch.cat([h, vel[:, None, :].expand(b, t, 2)], dim=-1))


class EncoderDecoder(nn.Module):
    """Encoder -> repeat vector -> decoder -> dense layer that also takes the velocity.

    ``encoder`` is ``"convlstm"`` (paper: ConvBiLSTM, kernel 3) or ``"lstm"``. ``decoder_input``
    ``"sequence"`` gives the decoder the encoder's output at each step instead of the repeated final state.
    """

    def __init__(self, width: int, steps: int, *, encoder: str, encoder_sizes: list[int], encoder_bidirectional: bool,
                 decoder_sizes: list[int], decoder_bidirectional: bool, encoder_dropout: float, decoder_dropout: float,
                 kernel: int = 3, decoder_input: str = "repeat"):
        super().__init__()
        self.steps = steps
        self.decoder_input = decoder_input
        self.encoder_kind = encoder
        if encoder == "convlstm":
            d = 2 if encoder_bidirectional else 1
            layers, c = [], 2
            for filters in encoder_sizes:
                layers.append(ConvLSTMLayer(c, filters, width, kernel=kernel, bidirectional=encoder_bidirectional))
                c = d * filters
            self.enc = nn.ModuleList(layers)
            self.enc_drop = nn.Dropout(encoder_dropout)
            code = c * width
        else:
            self.enc = LSTMStack(2 * width, encoder_sizes, bidirectional=encoder_bidirectional, dropout=encoder_dropout)
            code = self.enc.out_features
        self.dec = LSTMStack(code, decoder_sizes, bidirectional=decoder_bidirectional, dropout=decoder_dropout)
        self.fc = nn.Linear(self.dec.out_features + 2, width)

    def encode(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The encoder's output at each step ``(B, T, code)`` and its final state ``(B, code)``."""
        b, t, _, s = x.shape
        if self.encoder_kind == "convlstm":
            for layer in self.enc:
                x, last = layer(x)
                x = self.enc_drop(x)
            return x.reshape(b, t, -1), self.enc_drop(last).reshape(b, -1)
        return self.enc(x.reshape(b, t, 2 * s))

    def forward(self, x: torch.Tensor, vel: torch.Tensor) -> torch.Tensor:
        b, t = x.shape[:2]
        outputs, code = self.encode(x)
        h, _ = self.dec(outputs if self.decoder_input == "sequence" else code[:, None, :].expand(b, t, code.shape[-1]))
        return self.fc(torch.cat([h, vel[:, None, :].expand(b, t, 2)], dim=-1))


def blend_plus_correction(x: torch.Tensor, vel: torch.Tensor, correction: torch.Tensor) -> torch.Tensor:
    """The normalised centre ``(B, T, S)``: linear blend of the neighbours in ``x`` plus the correction."""
    w = vel[:, 0].reshape(-1, 1, 1)
    return (1.0 - w) * x[:, :, 0] + w * x[:, :, 1] + correction


def build_network(arch: str, model: dict, *, width: int, steps: int) -> nn.Module:
    """The network of interpolator ``arch`` with the sizes in ``model`` (see :mod:`.config`)."""
    if arch in ("lstm", "bilstm"):
        net = SequenceRegressor(width, sizes=list(model["sizes"]), bidirectional=arch == "bilstm",
                                dropout=model["dropout"])
    else:
        encoder = {"convbilstm": ("convlstm", True, True), "convlstm-ed": ("convlstm", False, False),
                   "bilstm-ed": ("lstm", True, True), "lstm-sae": ("lstm", False, False)}[arch]
        net = EncoderDecoder(
            width, steps, encoder=encoder[0], encoder_sizes=list(model["encoder_sizes"]),
            encoder_bidirectional=encoder[1], decoder_sizes=list(model["decoder_sizes"]),
            decoder_bidirectional=encoder[2], encoder_dropout=model["encoder_dropout"],
            decoder_dropout=model["decoder_dropout"], kernel=model.get("kernel", 3),
            decoder_input=model["decoder_input"],
        )
    nn.init.zeros_(net.fc.weight)
    nn.init.zeros_(net.fc.bias)
    return net
