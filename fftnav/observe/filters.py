"""The filter bank h1 / h2 and batched FFT filtering (paper Sec. III-B to III-D).

A :class:`FilterBank` is designed once per (robot geometry, beams M, field of view, max range
R) and keeps the spectra H1 and H2 ("stored in ROM"): filtering K scans is one real FFT of the
stacked ``(2K, M)`` batch (clipped scans for h1, raw scans for h2) zero-padded to ``fft_size``,
one product and one inverse FFT (``numpy.fft``). Pure numpy / scipy.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft

from fftnav.errors import FftnavError
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.scan import angle_increment_rad, is_full_circle
from fftnav.validate import check_choice, check_number

__all__ = ["FilterBank", "MODES", "DEFAULT_BLIND_RAD"]

MODES = ("linear", "circular")
#: Blind sector at the back of the paper's simulated 360 degree lidar (Sec. IV-B).
DEFAULT_BLIND_RAD = math.radians(15.0)
_MINUS_3DB = 10.0 ** (-3.0 / 20.0)
#: How many batch sizes K keep their repeated ``(2K, fft_size // 2 + 1)`` spectra.
_KEEP_BATCH_SIZES = 8


def _cutoff_3db(h: np.ndarray) -> float:
    """First frequency (cycles per beam) where ``|H|`` falls to -3 dB, from a dense FFT; the
    Nyquist frequency 0.5 if it never does (a one-tap filter passes every frequency).

    >>> _cutoff_3db(np.array([1.0]))
    0.5
    """
    n = 1 << 16
    mag = np.abs(np.fft.rfft(h, n))
    below = mag < _MINUS_3DB * mag[0]
    if not below.any():
        return 0.5
    k = int(np.argmax(below))
    # linear interpolation between bins k-1 and k
    m0, m1 = mag[k - 1] / mag[0], mag[k] / mag[0]
    return (k - 1 + (m0 - _MINUS_3DB) / (m0 - m1)) / n


def _checked(geometry: RobotGeometry, *, beams: int, fov_rad: float, range_m: float, mode: str,
             blind_rad: float | None) -> tuple[float, bool, float, int]:
    """:class:`FilterBank`'s parameters checked: ``(increment_rad, full_circle, blind_rad,
    Tc)``, the blind sector defaulted (15 degrees for a full circle, else 0)."""
    if not isinstance(geometry, RobotGeometry):
        raise FftnavError(f"geometry must be a RobotGeometry, got geometry={geometry!r}")
    inc = angle_increment_rad(beams, fov_rad)  # validates beams >= 2 and fov_rad
    if not (math.isfinite(range_m) and range_m >= geometry.l_th_m):
        raise FftnavError(
            f"range_m must be finite and >= l_th_m={geometry.l_th_m:.4g}, "
            f"got range_m={range_m!r}"
        )
    check_choice("mode", mode, MODES)
    full = is_full_circle(fov_rad)
    if mode == "circular" and not full:
        raise FftnavError(
            f"mode='circular' needs a full 360 degree field of view, got fov_rad={fov_rad!r}"
        )
    if blind_rad is None:
        blind_rad = DEFAULT_BLIND_RAD if full else 0.0
    if not (check_number("blind_rad", blind_rad, low=0) < fov_rad):
        raise FftnavError(f"blind_rad must be < fov_rad={fov_rad!r}, "
                          f"got blind_rad={blind_rad!r}")
    tc = math.ceil(geometry.alpha_rad / inc - 1e-9)
    if beams < tc:
        raise FftnavError(f"beams must be an integer >= Tc={tc}, got beams={beams}")
    return inc, full, blind_rad, tc


class FilterBank:
    """Filters h1 (safe directions, eq. (h1)) and h2 (dimension reduction, eq. (h2)).

    Parameters
    ----------
    geometry : RobotGeometry
        Robot model giving l_th (m) and alpha (rad), eqs. (1)-(2).
    beams : int
        Beams per scan M; must be ``>= Tc``.
    fov_rad : float
        Field of view Theta in radians, ``(0, 2 pi]``.
    range_m : float
        Maximum range R in metres; ``>= l_th`` (otherwise no direction can ever be safe).
    mode : {"linear", "circular"}
        ``"linear"``: the paper's zero-padded linear convolution (windows running past the scan
        ends are not safe). ``"circular"``: wrap-around filtering, full circle only.
    blind_rad : float, optional
        Width of the blind sector at the back (rad) in which extrema are ignored. Default 15 deg
        for a full circle, 0 for a partial field of view.

    Attributes
    ----------
    increment_rad : float
        Angle between beams (rad).
    f0 : float
        Analog cutoff Theta / alpha, eq. (f_0).
    fc : float
        Digital cutoff increment / alpha in cycles per beam (``Theta / (M alpha)`` for a full
        circle), eq. (f_c).
    tc : int
        ``Tc = ceil(1 / fc)``: beams spanning alpha.
    window_beams : int
        Width of the centred safety window: ``Tc`` if odd else ``Tc + 1``.
    n1, n2 : int
        Filter lengths (odd: M+1 if M is even else M).
    n0 : int
        The paper's FFT length N0 (smallest power of two > 2 max(M, N1, N2) and
        > M + N - 1; 1024 for M = 360) in linear mode, M in circular mode.
    fft_size : int
        FFT length actually used: in linear mode the fastest length ``>= M + tau`` (540 for
        M = 360), which yields exactly the same aligned output slice as N0 (the wrapped part of
        the circular convolution falls outside the slice); M in circular mode.
    h1, h2 : ndarray
        Impulse responses, lengths ``n1`` and ``n2``; ``h1`` sums to 1 and is ``1/window_beams``
        on its centred support; ``h2`` is a Blackman-windowed sinc normalised to sum 1.
    H1, H2 : ndarray
        Their N0-point real-FFT spectra (length ``n0 // 2 + 1``), as plotted in Figs. 3b / 5b.
    cutoff_3db_h1, cutoff_3db_h2 : float
        Measured -3 dB frequencies of h1 and h2, cycles per beam.
    threshold : float
        Normalised planning distance ``l_th / R``.
    """

    def __init__(
        self,
        geometry: RobotGeometry,
        *,
        beams: int = 360,
        fov_rad: float = 2.0 * math.pi,
        range_m: float = 3.0,
        mode: str = "linear",
        blind_rad: float | None = None,
    ) -> None:
        inc, full, blind_rad, tc = _checked(geometry, beams=beams, fov_rad=fov_rad,
                                            range_m=range_m, mode=mode, blind_rad=blind_rad)
        self.geometry, self.beams, self.fov_rad, self.range_m = (
            geometry,
            int(beams),
            fov_rad,
            range_m,
        )
        self.mode, self.blind_rad, self.full_circle = mode, float(blind_rad), full
        self.increment_rad = inc
        self.f0 = fov_rad / geometry.alpha_rad
        self.fc = inc / geometry.alpha_rad
        self.tc = tc
        self.window_beams = tc if tc % 2 else tc + 1
        self.threshold = geometry.l_th_m / range_m
        n = beams + 1 if beams % 2 == 0 else beams
        self.n1 = self.n2 = n
        self.tau = (n - 1) // 2
        self._design_filters()
        self._repeated: dict[int, np.ndarray] = {}

    def _design_filters(self) -> None:
        """h1, h2, their measured cutoffs, the FFT lengths and the stored spectra."""
        n, beams = self.n1, self.beams
        h1 = np.zeros(n)
        half = self.window_beams // 2
        h1[self.tau - half : self.tau + half + 1] = 1.0 / self.window_beams
        k = np.arange(n) - self.tau
        h2 = 2.0 * self.fc * np.sinc(2.0 * self.fc * k) * np.blackman(n)
        self.h1, self.h2 = h1, h2 / h2.sum()
        self.cutoff_3db_h1 = _cutoff_3db(self.h1)
        self.cutoff_3db_h2 = _cutoff_3db(self.h2)

        kernels = np.stack([self.h1, self.h2])
        if self.mode == "linear":
            need = max(2 * max(beams, n), beams + n - 1)
            self.n0 = 1 << need.bit_length()  # smallest power of two > need
            # the aligned slice [tau, tau + M) of a circular convolution of length L equals the
            # linear one as soon as L >= M + tau: use the fastest such length
            self.fft_size = scipy.fft.next_fast_len(beams + self.tau, real=True)
            self._spectra = scipy.fft.rfft(kernels, self.fft_size, axis=1)
        else:  # fold the centred kernels onto the circle of M beams
            self.n0 = self.fft_size = beams
            folded = np.zeros((2, beams))
            np.add.at(folded, (slice(None), k % beams), kernels)
            self._spectra = scipy.fft.rfft(folded, beams, axis=1)
        self.H1, self.H2 = scipy.fft.rfft(kernels, self.n0, axis=1)

    def __repr__(self) -> str:
        return (
            f"FilterBank(M={self.beams}, fov={math.degrees(self.fov_rad):.4g} deg, "
            f"R={self.range_m} m, Tc={self.tc}, window={self.window_beams}, N0={self.n0}, "
            f"fft_size={self.fft_size}, "
            f"mode={self.mode!r})"
        )

    def filter(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Filter normalised scans: ``y1 = h1 * clip(s, 0, l_th/R)`` and ``y2 = h2 * s``.

        Parameters
        ----------
        s : ndarray, shape (K, M)
            Normalised scans ``d / R`` in ``[0, 1]`` (already sanitised).

        Returns
        -------
        y1, y2 : ndarray, shape (K, M)
            Group-delay aligned filter outputs (normalised units); ``y1`` is eq. (y1 for safe)'s
            left side, ``y2`` the weighted mean depth of Sec. III-D.
        """
        k = s.shape[0]
        stacked = np.empty((2 * k, s.shape[1]))
        stacked[k:] = s
        np.minimum(s, self.threshold, out=stacked[:k])
        return self._run(stacked)

    def filter_ranges(self, ranges_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`filter` of raw ranges in metres, sanitised and normalised on the way.

        ``ranges_m`` is a float ``(K, M)`` array (see :func:`fftnav.observe.scan.as_scan_batch`);
        ``+inf`` and readings ``>= R`` read as R, NaN and negative readings as 0 (as
        :func:`fftnav.observe.scan.sanitize_ranges`), then ``s = d / R`` (eq. "sensor data"). The
        result equals ``filter(sanitize_ranges(ranges_m, range_m=R) / R)`` exactly, in fewer passes
        over the data (they write straight into the FFT input).
        """
        k = ranges_m.shape[0]
        stacked = np.empty((2 * k, ranges_m.shape[1]))
        raw = stacked[k:]
        np.minimum(ranges_m, self.range_m, out=raw)  # +inf -> R, NaN stays NaN
        np.fmax(raw, 0.0, out=raw)  # NaN and negative -> 0 (blocked)
        np.divide(raw, self.range_m, out=raw)
        np.minimum(raw, self.threshold, out=stacked[:k])
        return self._run(stacked)

    def filter_h1(self, s: np.ndarray) -> np.ndarray:
        """Only ``y1 = h1 * clip(s, 0, l_th/R)``, shape (K, M) (half the FFT work of
        :meth:`filter`)."""
        spec = _rfft(np.minimum(s, self.threshold), self.fft_size)
        spec *= self._spectra[0]
        return self._inverse(spec)

    def _run(self, stacked: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Filter ``(2K, M)`` rows, ``clip(s)`` for h1 then ``s`` for h2: one real FFT
        zero-padded to ``fft_size``, one product with the stored spectra (kept repeated to 2K
        rows for a few batch sizes), one inverse FFT."""
        k = stacked.shape[0] // 2
        spec = _rfft(stacked, self.fft_size)
        spec *= self.repeated_spectra(k)
        out = self._inverse(spec)
        return out[:k], out[k:]

    def repeated_spectra(self, k: int) -> np.ndarray:
        """``(2K, fft_size // 2 + 1)`` complex: H1 for the first K rows, H2 for the last K, the
        filters of K stacked scans (kept for a few batch sizes; read-only)."""
        spectra = self._repeated.get(k)
        if spectra is None:
            if len(self._repeated) >= _KEEP_BATCH_SIZES:
                self._repeated.clear()
            spectra = self._repeated[k] = np.repeat(self._spectra, k, axis=0)
            spectra.flags.writeable = False
        return spectra

    def _inverse(self, spec: np.ndarray) -> np.ndarray:
        out = np.fft.irfft(spec, self.fft_size, axis=1)
        return out[:, self.tau : self.tau + self.beams] if self.mode == "linear" else out


def _rfft(x: np.ndarray, n: int) -> np.ndarray:
    """Real FFT of each row, zero-padded to ``n`` (``numpy.fft``: single-threaded, and on
    this project's batches faster than ``scipy.fft``, whose padding and dispatch cost more;
    both run pocketfft, with bit-identical results here)."""
    if x.shape[1] == n:
        return np.fft.rfft(x, axis=1)
    padded = np.zeros((x.shape[0], n))
    padded[:, : x.shape[1]] = x
    return np.fft.rfft(padded, axis=1)
