"""The coordinates' low-pass filter and sample period (biomech/gait_signals): OpenSim's Butterworth
against SciPy's own forward-backward filter, up to the Nyquist frequency, and the Nyquist frequency of a
record whose time stamps were rounded."""
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from ocp_constraints.biomech.gait import run_inverse_dynamics
from ocp_constraints.biomech.gait_signals import _opensim_iir, _pad, check_cutoff
from ocp_constraints.biomech.opensim_files import read_motion
from ocp_constraints.errors import GaitError

G = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim-gait2354-subject01"
MODEL, IK, GRF = G / "subject01_simbody.osim", G / "subject01_walk1_ik.mot", G / "subject01_walk1_grf.mot"


@pytest.mark.parametrize("fraction", [0.05, 0.2, 0.5, 0.9, 0.99, 0.9967])
def test_the_filter_is_scipys_filtfilt_with_the_same_padding_up_to_the_nyquist_frequency(fraction):
    """SciPy's ``butter(3)`` run by ``filtfilt`` (its own code: ``lfilter`` from ``lfilter_zi``, odd padding of
    half the record as OpenSim pads), on the 60 Hz gait2354 motion: the same to 1e-9 rad at every cutoff. Near
    the Nyquist frequency the filter passes nearly everything: OpenSim's start (its output set to the first
    three inputs) rang there, and moved hip flexion by 1.29 rad at 29.9 Hz."""
    motion = read_motion(IK)
    t, y = motion.time, np.column_stack([motion.column(c) for c in ("hip_flexion_r", "knee_angle_r", "pelvis_tx")])
    dt = (t[-1] - t[0]) / (len(t) - 1)
    fc = fraction * 0.5 / dt
    n = len(t) // 2
    ours = _opensim_iir(np.column_stack([_pad(y[:, k], n) for k in range(y.shape[1])]), dt, fc)[n:-n]
    b, a = signal.butter(3, fraction)
    theirs = signal.filtfilt(b, a, y, axis=0, padtype="odd", padlen=n)
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)
    if fraction > 0.99:
        assert np.abs(ours - y).max() < 1e-3


def test_a_cutoff_just_below_the_nyquist_frequency_gives_the_unfiltered_loads():
    """29.9 Hz on 60 Hz data: the filter nearly passes everything, so away from the ends (where the filtered
    record is splined with its padding, the unfiltered one without) the generalized forces are those of
    ``--no-filter`` to within 5% of the largest (measured: 10.5 N m of 569, 1.8%; they were 3,480 N m RMS off OpenSim's in
    hip flexion at 29 Hz)."""
    near = run_inverse_dynamics(MODEL, IK, GRF, cutoff=29.9).generalized_forces[5:-5]
    raw = run_inverse_dynamics(MODEL, IK, GRF, cutoff=None).generalized_forces[5:-5]
    assert np.abs(near - raw).max() <= 0.05 * np.abs(raw).max()


def test_the_nyquist_frequency_of_rounded_time_stamps_is_that_of_the_record(tmp_path):
    """120 Hz written to 4 decimals (steps of 0.0083 and 0.0084 s, as the JW files): the Nyquist frequency is
    60 Hz, from the record's span, not 60.24 Hz from the median step; 60.2 Hz is refused, 59.9 Hz taken."""
    motion = read_motion(IK)
    t = np.round(motion.time[0] + np.arange(len(motion.time)) / 120.0, 4)
    assert set(np.round(np.diff(t), 4)) == {0.0083, 0.0084}
    motion.time = t
    with pytest.raises(GaitError, match=r"cutoff 60\.2 Hz is at or above the Nyquist frequency 60 Hz"):
        check_cutoff(60.2, motion)
    assert check_cutoff(59.9, motion) == 59.9
