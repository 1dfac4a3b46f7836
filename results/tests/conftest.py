"""Setup of the experiments' tests (`python -m pytest results/tests -q` from the repository root): the product
suite's setup and fixtures (tests/conftest.py), and the analysis scripts of results/ importable by name."""
import importlib.util
import pathlib
import sys

RESULTS = pathlib.Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("stitchjax_product_conftest", RESULTS.parent / "tests" / "conftest.py")
_product = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_product)  # sets JAX_PLATFORMS, the compilation and dataset caches, XLA flags

shared_data = _product.shared_data
tiny_run = _product.tiny_run

if str(RESULTS) not in sys.path:
    sys.path.insert(0, str(RESULTS))
