"""The sampling spec: checked once when built, hashable, the paper's and a model.json entry's, changed copies."""
import dataclasses

import pytest

from stitchjax.sample import footlock
from stitchjax.sample.sampling import Sampling
from stitchjax.sample.trained_model import InbetweenError


def test_paper_and_model_json_sampling():
    paper = Sampling.paper()
    assert (paper.noise_scale, paper.noise_correlation, paper.noise_ramp_steps, paper.search) == (1.0, 0.0, 0, 0)
    assert paper.foot_lock is False and not paper.locks_feet and paper.foot_lock_config is None
    chosen = Sampling.from_json({"noise_scale": 2, "noise_ramp_steps": 4}, foot_lock=True)
    assert chosen.noise == {"noise_scale": 2.0, "noise_correlation": 0.0, "noise_ramp_steps": 4}
    assert isinstance(chosen.noise_scale, float) and chosen.foot_lock_config is footlock.DEFAULT_CONFIG
    assert Sampling.from_json(None) == paper
    with pytest.raises(InbetweenError, match="unknown noise_speed"):
        Sampling.from_json({"noise_speed": 1.0})


def test_sampling_is_frozen_hashable_and_replace_checks_again():
    eager = dataclasses.replace(footlock.DEFAULT_CONFIG)
    a, b = Sampling(0.5, 0.9, 3, search=2, foot_lock=eager), Sampling(0.5, 0.9, 3, search=2, foot_lock=eager)
    assert a == b and hash(a) == hash(b) and len({a, b, Sampling()}) == 2
    assert a.foot_lock_config is eager
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.search = 3
    wider = a.replace(noise_scale=2.0, search=None)  # None keeps a field
    assert (wider.noise_scale, wider.search, wider.noise_correlation) == (2.0, 2, 0.9)
    with pytest.raises(InbetweenError, match="noise_scale must be"):
        a.replace(noise_scale=-1.0)
    with pytest.raises(InbetweenError, match="unknown noise_speed"):
        a.replace(noise_speed=1.0)


@pytest.mark.parametrize("bad, message", [
    (dict(noise_scale=float("nan")), "noise_scale must be a finite number"),
    (dict(noise_correlation=1.5), r"noise_correlation must be in \[0, 1\]"),
    (dict(noise_ramp_steps=2.5), "noise_ramp_steps must be a whole number"),
    (dict(search=-1), "search must be 0"),
    (dict(search=1.5), "search must be 0"),
    (dict(foot_lock="on"), "foot_lock must be False, True or a footlock.FootLockConfig"),
])
def test_bad_sampling_is_refused_naming_the_field(bad, message):
    with pytest.raises(InbetweenError, match=message):
        Sampling(**bad)
