"""Every public name is documented, in the stubs and at run time."""

import inspect
import pathlib

import lamina

STUB = pathlib.Path(lamina.__file__).with_name("_lamina.pyi").read_text()


def test_every_public_name_has_a_docstring_and_a_stub():
    for name in lamina.__all__:
        obj = getattr(lamina, name)
        if name == "__version__":
            assert obj == "0.1.0" or obj.count(".") == 2
            continue
        assert (obj.__doc__ or "").strip(), name
        assert f"def {name}(" in STUB or f"class {name}" in STUB, name
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                assert (getattr(member, "__doc__", None) or "").strip(), f"{name}.{attr}"
                assert attr in STUB, f"{name}.{attr} missing from the stubs"


def test_package_is_typed():
    assert pathlib.Path(lamina.__file__).with_name("py.typed").exists()
