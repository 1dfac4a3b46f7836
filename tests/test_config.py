"""Config: paper values, overrides parsed by field type, JSON round trip, named configs, removed fields."""
import dataclasses
import json
import pathlib

import pytest

from stitchjax import config as C


def test_reference_config_has_paper_values():
    c = C.load_config("lafan1")
    assert c.train.learning_rate == 1e-4 and (c.train.adam_b1, c.train.adam_b2) == (0.5, 0.9)
    assert c.train.weight_decay == 1e-5 and c.train.batch_size == 32
    assert c.model.num_experts == 4
    assert (c.loss.beta_rotation, c.loss.beta_velocity, c.loss.beta_contact) == (1.0, 1.0, 0.1)
    assert (c.loss.kl_weight, c.loss.stitch_weight, c.loss.fk_weight) == (1.0, 0.5, 0.5)
    assert (c.loss.disc_weight, c.loss.gen_weight) == (0.1, 0.1)
    assert (c.train.min_length, c.train.length_step, c.train.epochs_per_length) == (5, 1, 2)
    assert c.data.num_joints == 22 and c.train.max_length + 2 == c.data.window


def test_overrides_parse_by_type():
    c = C.apply_overrides(C.Config(), [
        "model.latent_dim=8", "loss.kl_weight=0.25", "model.bidirectional=false",
        "model.decoder_widths=16,32", "model.update_anchor=interpolation", "name=tiny"])
    assert c.model.latent_dim == 8 and isinstance(c.model.latent_dim, int)
    assert c.loss.kl_weight == 0.25 and c.model.bidirectional is False
    assert c.model.decoder_widths == (16, 32) and c.model.update_anchor == "interpolation" and c.name == "tiny"
    assert C.Config().model.latent_dim != 8  # the original is unchanged (frozen dataclasses)


@pytest.mark.parametrize("bad, words", [
    ("model.no_such_field=1", "no field"), ("nosection.x=1", "unknown section"),
    ("model.latent_dim=abc", "latent_dim"), ("model.bidirectional=maybe", "boolean"), ("model.latent_dim", "="),
    ("model.matmul_dtype=float16", "one of float32, bfloat16"), ("model.posterior=both", "one of next_frame, none"),
    ("model.noise_correlation=0.5", "model.noise_correlation was removed .*656e31b")])
def test_bad_overrides_raise_clear_errors(bad, words):
    with pytest.raises(C.ConfigError, match=words):
        C.apply_overrides(C.Config(), [bad])


def _inert(config):
    return C.inert_fields(config.model.posterior, C.extensions_on(config))


def test_posterior_only_fields_are_named_inert_and_refused_as_overrides_with_posterior_none():
    cpu = C.apply_overrides(C.load_config("lafan1_cpu"), ["loss.free_bits=1", "loss.prior_sample_fraction=0.5"])
    assert _inert(cpu) == ()  # with a posterior every field acts
    none = C.apply_overrides(cpu, ["model.posterior=none"])
    assert set(_inert(none)) == {"loss.free_bits", "loss.prior_sample_fraction"}  # the config's own values
    overrides = ["model.posterior=none", "loss.prior_sample_fraction=0.25", "loss.free_bits=2"]
    with pytest.raises(C.ConfigError, match="loss.prior_sample_fraction, loss.free_bits change nothing"):
        C.check_overrides_take_effect(_inert(C.apply_overrides(cpu, overrides)), overrides)
    with_posterior = C.apply_overrides(cpu, overrides[1:])
    C.check_overrides_take_effect(_inert(with_posterior), overrides[1:])  # with the posterior: fine
    # the same fields at their defaults, or fields that act on "none" too (the KL warm-up), are not refused
    fine = ["model.posterior=none", "loss.free_bits=0", "loss.kl_warmup_steps=100"]
    C.check_overrides_take_effect(_inert(C.apply_overrides(cpu, fine)), fine)
    assert {".".join(name) for name in C.POSTERIOR_ONLY_FIELDS} <= set(C.EXTENSIONS)  # what extensions_on names


def test_dict_and_json_round_trip(tmp_path):
    c = C.apply_overrides(C.load_config("lafan1"), ["model.encoder_widths=8,8,4", "train.batch_size=4"])
    assert C.from_dict(C.to_dict(c)) == c
    (tmp_path / "config.json").write_text(json.dumps(C.to_dict(c)))
    assert C.from_dict(json.loads((tmp_path / "config.json").read_text())) == c
    with pytest.raises(C.ConfigError, match="unknown field"):
        C.from_dict({"model": {"bogus": 1}})


def test_load_config_errors_and_env(tmp_path, monkeypatch):
    with pytest.raises(C.ConfigError, match="no config named"):
        C.load_config("does_not_exist")
    (tmp_path / "mine.py").write_text(
        "from stitchjax.config import Config\n\ndef get_config():\n    return Config(name='mine')\n")
    monkeypatch.setenv("STITCHJAX_CONFIGS", str(tmp_path))
    assert C.load_config("mine").name == "mine"


def test_every_field_documents_its_choice():
    """Each field line in config.py carries a comment ("# paper", "# reason: ..." or a DESIGN pointer)."""
    source = pathlib.Path(C.__file__).read_text().splitlines()
    for cls in (C.DataConfig, C.ModelConfig, C.LossConfig, C.TrainConfig, C.PhaseConfig):
        for field in dataclasses.fields(cls):
            lines = [ln for ln in source if ln.strip().startswith(f"{field.name}:")]
            assert lines, field.name
            idx = source.index(lines[0])
            assert "#" in lines[0] or "#" in source[idx + 1], f"{cls.__name__}.{field.name} has no comment"


def test_override_choices_match_what_the_networks_accept():
    from stitchjax.accel import fast_rollout
    from stitchjax.accel import matmul as accel_matmul

    assert set(C.CHOICES[("model", "matmul_dtype")]) == set(accel_matmul.MATMUL_DTYPES)
    assert set(C.CHOICES[("train", "scan_remat")]) == set(fast_rollout.SCAN_REMAT)


def test_the_paper_configs_turn_no_extension_on_and_every_extension_is_a_field():
    fields = {f"{s}.{f.name}" for s in ("data", "model", "loss", "train")
              for f in dataclasses.fields(getattr(C.Config(), s))}
    assert set(C.EXTENSIONS) <= fields and len(set(C.EXTENSIONS)) == len(C.EXTENSIONS)
    assert C.extensions_on(C.load_config("lafan1")) == ()
    assert C.extensions_on(C.load_config("quickstart")) == () and C.extensions_on(C.load_config("tiny")) == ()
    cpu = C.load_config("lafan1_cpu")  # the paper at CPU widths, with the validation split held out
    assert C.extensions_on(cpu) == ("data.validation_files",)
    assert (cpu.loss.kl_weight, cpu.loss.stitch_weight, cpu.loss.fk_weight, cpu.loss.gen_weight) == (1.0, 0.5, 0.5, 0.1)
    assert cpu.loss == C.load_config("lafan1").loss and cpu.model.posterior == "next_frame"
    on = C.extensions_on(C.apply_overrides(cpu, ["loss.foot_velocity_weight=16", "data.mirror=true"]))
    assert on == ("data.validation_files", "data.mirror", "loss.foot_velocity_weight")
    release = C.extensions_on(C.load_config("lafan1_cpu_release"))
    assert {"data.random_starts", "data.mirror", "data.extra_train_dirs", "loss.foot_skate_weight"} <= set(release)


def test_a_saved_config_lacking_a_field_outside_the_extensions_is_refused_naming_it():
    saved = C.to_dict(C.load_config("tiny"))
    del saved["model"]["update_anchor"]  # an extension: its default is the paper's (off)
    del saved["data"]["mirror"]
    for name in ("discriminators", "lstm"):  # Appendix D's switches: a run saved before them had both parts
        del saved["model"][name]
    assert C.from_dict(saved) == C.load_config("tiny")
    del saved["model"]["posterior"], saved["phase"]["steps"]
    with pytest.raises(C.ConfigError, match="lacks model.posterior, phase.steps: add them"):
        C.from_dict(saved)


def test_a_removed_field_loads_at_the_value_kept_and_is_refused_at_any_other_naming_its_last_commit():
    """A config saved before a field was removed (the shipped model's among them) loads when the field holds
    the value the code now always uses; any other value is refused, naming the field and the last commit with
    it, never silently trained or sampled another way."""
    shipped = json.loads((pathlib.Path(C.__file__).parent / "pretrained" / "lafan1_cpu_release" /
                          "model.json").read_text())["config"]
    retired = {(s, f) for s, fields in shipped.items() if isinstance(fields, dict) for f in fields
               if (s, f) in C.RETIRED_FIELDS}
    assert ("model", "noise_correlation") in retired and ("phase", "include_reversed") in retired
    assert {("loss", "near_keyframe_weight"), ("data", "position_scale"), ("data", "num_contacts"),
            ("train", "eval_samples")} <= retired
    config = C.from_dict(shipped)
    assert config.name == "lafan1_cpu_release" and config.loss.foot_skate_weight == 128.0
    for section, field in sorted(C.RETIRED_FIELDS):
        retired_field = C.RETIRED_FIELDS[(section, field)]
        assert not hasattr(getattr(config, section), field)
        if retired_field is None:  # read nowhere: dropped at any value
            continue
        saved = C.to_dict(config)
        saved[section][field] = retired_field.value
        assert C.from_dict(saved) == config
        other = {bool: lambda v: not v, str: lambda v: v + "_other"}.get(type(retired_field.value), lambda v: v + 7)
        saved[section][field] = other(retired_field.value)
        with pytest.raises(C.RetiredFieldError, match=f"{section}.{field}=.*commit {retired_field.commit}"):
            C.from_dict(saved)


def test_the_validation_takes_of_every_config_are_training_files_never_test_files(shared_data):
    from stitchjax.data import datasets, lafan1

    data_dir = shared_data / "lafan1"
    test_stems = {p.name.split(".")[0] for p in lafan1.list_files(data_dir)["subject5"]}
    for name in ("lafan1_cpu", "lafan1_cpu_release"):
        data = C.load_config(name).data
        files = datasets.validation_files(data_dir, data)
        stems = {p.name.split(".")[0] for p in files}
        assert stems == set(data.validation_files) and not stems & test_stems
        assert all(any(s.endswith("_" + subject) for subject in data.train_subjects) for s in stems)
    for bad in ("obstacles1_subject5", "walk4_subject1,ground1_subject5"):
        data = C.apply_overrides(C.load_config("lafan1_cpu"), [f"data.validation_files={bad}"]).data
        with pytest.raises(ValueError, match="is a test file"):
            datasets.validation_files(data_dir, data)


def _differences(a: C.Config, b: C.Config) -> set:
    """"section.field" of every field where two configs differ (name left out)."""
    return {f"{s}.{f.name}" for s in C._SECTIONS for f in dataclasses.fields(getattr(a, s))
            if getattr(getattr(a, s), f.name) != getattr(getattr(b, s), f.name)}


def test_every_named_config_keeps_its_values():
    """Each file in configs/ loads under its own name and sets what it is documented to set (a few key fields)."""
    configs = {name: C.load_config(name) for name in C.available_configs()}
    assert all(config.name == name for name, config in configs.items())
    paper = configs["lafan1"]
    assert paper == dataclasses.replace(C.Config(), name="lafan1")  # the paper: every default
    quick = configs["quickstart"]
    assert (quick.data.window, quick.data.offset, quick.model.lstm_size, quick.model.latent_dim) == (24, 8, 64, 16)
    assert (quick.train.batch_size, quick.train.learning_rate, quick.train.max_length) == (16, 1e-3, 22)
    assert (quick.train.max_steps, quick.train.length_buckets, quick.phase.steps) == (800, (), 500)
    cmu = configs["cmu"]  # quickstart on the CMU skeleton: only data fields differ
    assert {f.split(".")[0] for f in _differences(cmu, quick)} == {"data"}
    assert (cmu.data.dataset, cmu.data.num_joints, cmu.data.unit_scale, cmu.data.train_subjects) == (
        "bvh_folder", 31, 5.6444, ())
    h36m = configs["h36m"]
    assert _differences(h36m, paper) == {"data.dataset", "data.train_subjects", "data.fps", "data.parents"}
    assert (h36m.data.num_joints, h36m.data.fps, h36m.data.window, h36m.data.offset) == (21, 25.0, 52, 20)
    tiny = configs["tiny"]
    assert (tiny.model.lstm_size, tiny.model.latent_dim, tiny.train.max_length) == (16, 4, 8)
    assert (tiny.phase.hidden_dim, tiny.phase.num_layers) == (16, 1)
    cpu = configs["lafan1_cpu"]
    assert _differences(cpu, paper) == {
        "data.validation_files", "model.encoder_widths", "model.lstm_size", "model.decoder_widths",
        "model.gating_widths", "model.disc_widths", "train.learning_rate", "train.length_step",
        "train.epochs_per_length", "train.length_buckets", "train.max_steps", "train.log_every",
        "train.checkpoint_every_steps", "train.eval_every", "train.eval_lengths", "phase.steps"}
    assert (cpu.model.lstm_size, cpu.train.learning_rate, cpu.train.length_buckets, cpu.train.max_steps) == (
        256, 5e-4, (15, 30, 50), 3000)
    release = configs["lafan1_cpu_release"]
    assert release.data.validation_files == cpu.data.validation_files and release.train.max_steps == 64000
    assert (release.loss.kl_weight, release.loss.foot_skate_weight, release.train.lr_decay_to) == (0.1, 128.0, 0.05)
    base = configs["paper_cpu"]  # lafan1_cpu with the release recipe's data options and a longer run
    assert _differences(base, cpu) == {"data.extra_train_dirs", "data.random_starts", "data.mirror",
                                       "train.max_steps", "train.checkpoint_every_steps", "train.eval_every",
                                       "train.eval_windows"}
    assert {f: getattr(base.data, f) for f in ("extra_train_dirs", "random_starts", "mirror")} == {
        f: getattr(release.data, f) for f in ("extra_train_dirs", "random_starts", "mirror")}
    assert C.extensions_on(base) == ("data.validation_files", "data.extra_train_dirs", "data.random_starts",
                                     "data.mirror")
    assert (base.train.max_steps, base.train.lr_decay_to, base.train.eval_lengths) == (10000, 1.0, (30, 50))
    h36m_cpu = configs["h36m_cpu"]  # paper_cpu's model, loss and schedule on h36m's data, no validation
    assert h36m_cpu.data == h36m.data and (h36m_cpu.model, h36m_cpu.loss, h36m_cpu.phase) == (
        base.model, base.loss, base.phase)
    assert _differences(h36m_cpu, base) - {f"data.{f.name}" for f in dataclasses.fields(C.DataConfig)} == {
        "train.eval_every"} and h36m_cpu.train.eval_every == 0 and C.extensions_on(h36m_cpu) == ()


def _ablations() -> dict:
    """configs/paper_cpu.py's ABLATIONS: name -> (the paper's label, the "section.field=value" it sets)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("paper_cpu_registry", C.configs_dir() / "paper_cpu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ABLATIONS, module.SEEDS


def test_each_ablation_differs_from_its_base_in_exactly_its_one_field():
    """Every ablation of the registry, on the CPU base and on the GPU-width lafan1, changes one field: the one it
    names, away from the paper's value; the base's seeds differ in train.seed alone."""
    ablations, seeds = _ablations()
    labels = [label for label, _ in ablations.values()]
    assert labels == ["w/o BS", "w/o SL", "w/o LI", "w/o BA", "w/o PM", "w/o D", "w/o LSTM"]
    for base_name in ("paper_cpu", "lafan1"):
        base = C.load_config(base_name)
        for name, (_, override) in ablations.items():
            field = override.split("=")[0]
            ablated = C.apply_overrides(base, [override])
            assert _differences(ablated, base) == {field}, (base_name, name)
    base = C.load_config("paper_cpu")
    assert len(seeds) >= 2 and seeds[0] == base.train.seed
    for seed in seeds[1:]:
        assert _differences(C.apply_overrides(base, [f"train.seed={seed}"]), base) == {"train.seed"}
    assert set(C.ABLATION_SWITCHES) <= {override.split("=")[0] for _, override in ablations.values()}


def test_a_variant_finds_its_base_beside_it(tmp_path, monkeypatch):
    """A configs folder loaded by path uses its own base, whatever STITCHJAX_CONFIGS names."""
    (tmp_path / "base.py").write_text(
        "from stitchjax.config import Config, ModelConfig\n\n"
        "def get_config():\n    return Config(name='base', model=ModelConfig(latent_dim=3))\n")
    (tmp_path / "child.py").write_text(
        "from stitchjax.config import variant\n\nget_config = variant('base', 'model.lstm_size=8', name='child')\n")
    monkeypatch.setenv("STITCHJAX_CONFIGS", str(tmp_path / "elsewhere"))
    child = C.load_config(str(tmp_path / "child.py"))
    assert (child.name, child.model.latent_dim, child.model.lstm_size) == ("child", 3, 8)
