"""Specs: the Config resolved once into small frozen specs that the losses, the rollout and the networks read."""
import ast
import dataclasses
import pathlib

import jax
import pytest

from stitchjax import config as C
from stitchjax import specs
from stitchjax.accel import matmul as accel_matmul
from stitchjax.model import losses, networks, objective, rollout
from stitchjax.skeleton import LAFAN1_FEET


def _imported_modules(module) -> set:
    tree = ast.parse(pathlib.Path(module.__file__).read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names |= {node.module or ""} | {alias.name for alias in node.names}
        elif isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
    return names


def test_the_model_imports_none_of_the_speed_machinery():
    """Only the training step chooses accel's fast paths: no module of stitchjax.model imports stitchjax.accel."""
    folder = pathlib.Path(networks.__file__).parent
    for path in sorted(folder.glob("*.py")):
        names = _imported_modules(type("M", (), {"__file__": str(path)}))
        assert not [name for name in names if "accel" in name], f"{path.name} imports stitchjax.accel"


def test_no_module_imports_from_the_package_init():
    """Modules import each other, never names defined in stitchjax/__init__.py (it sits above them all)."""
    package = pathlib.Path(C.__file__).parent
    for path in sorted(package.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module == "stitchjax" and node.level == 0:
                for alias in node.names:
                    is_module = (package / f"{alias.name}.py").is_file() or (package / alias.name).is_dir()
                    assert is_module, f"{path.relative_to(package)} imports {alias.name} from stitchjax/__init__.py"


def test_losses_take_the_skeleton_from_a_spec_not_from_the_dataset_registry():
    for module in (losses, objective):
        assert not {"datasets", "conform", "stitchjax.data.datasets", "stitchjax.data.conform"} & _imported_modules(module)
    skeleton = specs.skeleton_spec(C.Config().data)
    assert skeleton.feet == tuple(LAFAN1_FEET)
    assert (skeleton.up_axis, skeleton.up_index, skeleton.up_sign) == ("+y", 1, 1)
    assert skeleton.parents == tuple(C.Config().data.parents) and skeleton.num_joints == 22
    assert (skeleton.position_scale, skeleton.velocity_scale) == (100.0, 10.0)
    folder = specs.skeleton_spec(C.apply_overrides(C.Config(), ["data.dataset=bvh_folder"]).data)
    assert folder.feet is None  # read per file: the foot terms refuse it, naming the field to unset
    with pytest.raises(ValueError, match="loss.foot_skate_weight"):
        objective._fixed_feet(folder, "loss.foot_skate_weight")


def test_specs_are_hashable_and_hold_only_what_their_readers_read():
    config = C.load_config("tiny")
    spec = specs.train_spec(config)
    assert hash(spec) == hash(specs.train_spec(config))  # a jit static argument, a cache key
    # a setting the rollout does not read leaves its spec (and the samplers compiled for it) unchanged
    bigger_batch = C.apply_overrides(config, ["train.batch_size=64"])
    assert rollout.rollout_spec(bigger_batch) == rollout.rollout_spec(config)
    assert rollout.rollout_spec(C.apply_overrides(config, ["model.stitch_buffer=3"])) != rollout.rollout_spec(config)
    # the training step's generator runs on accel's layers (stitchjax.accel.matmul)
    assert spec.rollout.generator == dataclasses.replace(networks.model_spec(config.model, config.data).generator, layers=accel_matmul.LAYERS)
    assert spec.loss.discriminators == networks.model_spec(config.model, config.data).discriminators
    assert (spec.loss.discriminators.short_window, spec.loss.discriminators.long_window) == (
        config.model.disc_short_window, config.model.disc_long_window)


def test_init_params_of_a_model_spec_has_the_checkpoint_layout():
    config = C.load_config("tiny")
    params = jax.eval_shape(lambda k: networks.init_params(networks.model_spec(config.model, config.data), k), jax.random.PRNGKey(0))
    assert set(params) == {"forward", "backward", "disc_short", "disc_long"}
    kernel = params["disc_long"]["params"]["temporal_conv"]["kernel"]
    assert kernel.shape[:2] == (config.model.disc_long_window, networks.disc_feature_dim(config.data.num_joints))
