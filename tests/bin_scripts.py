"""The command-line tools of bin/ loaded as modules, so tests call their main() and helpers in-process."""
import importlib.machinery
import importlib.util
import pathlib

BIN = pathlib.Path(__file__).resolve().parent.parent / "bin"


def load_cli(name: str):
    """bin/<name> as a module (its main(), build_parser() and helpers), without starting a process."""
    loader = importlib.machinery.SourceFileLoader(f"bin_{name}", str(BIN / name))
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(module)
    return module
