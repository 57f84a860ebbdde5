"""docs/architecture.md, "Adding a machine", followed once: a rack-and-pinion axis as a ``two_mass`` machine.

The machine is the recipe's steps 1-2 and nothing else (a ``MachineEntry`` naming its twin, its plant structure, its
experiments; registered in ``machines.registry._machines``). Everything after that acts on the plant structure and
must reach the new machine unchanged: the command line's twin lookup, the FRF experiment, the two-mass fit, the
tuner, the one delivery exit, the runtime chosen by the gains file's kind and a tracking run under it. The test
proves the recipe can fail too: the machine is unknown until it is registered.
"""

from __future__ import annotations

import numpy as np
import pytest

PINION_RADIUS_M = 0.025
"""A 50 mm pitch-diameter pinion: 0.025 m of rack travel per radian (the lead of the two-mass model)."""


def _rackpinion_entry():
    from feedtune.machines.ballscrew.twin import BallScrewTwin, TwinParams
    from feedtune.machines.registry import MachineEntry

    def make_twin(overrides: dict, ideal: bool):
        # the same motor; the pinion's lead (8x the screw's: the safety envelope in m grows with it) and a stiffer
        # rack-side spring
        base = TwinParams.ideal() if ideal else TwinParams()
        base = base.with_overrides({"lead_m_per_rad": str(PINION_RADIUS_M), "k": "420", "envelope_m": "0.01"})
        return BallScrewTwin(base.with_overrides(overrides))

    return MachineEntry(name="rackpinion", title="rack-and-pinion axis", plant="two_mass", make_twin=make_twin,
                        experiments="feedtune.machines.ballscrew.experiments",
                        params="feedtune.machines.ballscrew.twin:TwinParams")


@pytest.fixture
def registered(monkeypatch):
    from feedtune.machines import registry

    known = registry._machines()
    entry = _rackpinion_entry()
    monkeypatch.setattr(registry, "_machines", lambda: {**known, entry.name: entry})
    return entry


def test_an_unregistered_machine_is_refused():
    from feedtune.cli.twin_options import twin_from_options
    from feedtune.errors import UsageError

    with pytest.raises(UsageError, match="unknown machine 'rackpinion'"):
        twin_from_options("rackpinion", None, False)


def test_a_rack_and_pinion_machine_needs_no_other_change(registered):
    from feedtune.cli.twin_options import twin_from_options
    from feedtune.control.filters import THESIS_FILTER_PACK
    from feedtune.identify.ballscrew import fit_ballscrew
    from feedtune.machines import load_runtime, machines_of
    from feedtune.machines.certificate import FrfSource
    from feedtune.sim.trajectory import point_to_point
    from feedtune.structures import plant_of, resolve
    from feedtune.tune.ppi import tune_ppi
    from feedtune.workflows.deliver import deliver

    assert "rackpinion" in machines_of("two_mass")
    twin = twin_from_options("rackpinion", None, False)  # what 'feedtune simulate --machine rackpinion' runs
    assert twin.params.lead == pytest.approx(PINION_RADIUS_M)
    experiments = resolve(registered.experiments)
    res = experiments.measure_frf(twin, f_lo=5.0, f_hi=1500.0, period_s=0.4, periods=4, seed=1)
    assert not res.tripped
    fit = fit_ballscrew(res.frf, lead_m_per_rad=PINION_RADIUS_M)  # the pinion radius, as for a screw's lead
    assert plant_of(fit.model).name == "two_mass"
    true = twin.params.model
    assert fit.model.k / true.k == pytest.approx(1.0, rel=0.15)  # the rack's spring, not the screw's (210 V/rad)

    design = tune_ppi(fit.model, filters=THESIS_FILTER_PACK, fs=twin.params.fs,
                      delay_samples=twin.params.delay_samples, frf=res.frf)
    delivery = deliver(design, [FrfSource.from_memory("frf.csv", res.frf)], where="rackpinion_ppi.toml")
    assert delivery.ok and delivery.document["kind"] == "ballscrew"
    runtime = load_runtime(delivery.document)  # chosen by the document's kind, whichever machine runs it
    move = point_to_point(0.05, v_max=0.2, a_max=2.0, j_max=100.0, fs=twin.fs, dwell_before=0.02, dwell_after=0.1)
    run = experiments.run_tracking(twin, runtime, move, seed=2)
    assert not run.tripped
    err = np.abs(run.log["e2"])  # x_ref - x2_table [m]: the rack's travel through the pinion's lead
    assert np.max(np.abs(run.log["x2_table"])) == pytest.approx(0.05, rel=0.05)
    assert err[-1] < 1e-4  # settled on the rack within 0.1 mm at the end of the dwell
