# the type stubs (stance/__init__.pyi) against the module: every public name, class member and
# parameter the module has is in them, and they name nothing the module lacks, so that they
# cannot go stale
import ast
import inspect
import pathlib
import re

import pytest

import stance

STUB = pathlib.Path(stance.__file__).with_name("__init__.pyi")
# the stubs' own type aliases (not names of the module)
ALIASES = {"Path", "Array", "Name", "Overrides"}
# attributes set on instances only, which the class itself does not show
INSTANCE_ONLY = {("DivergenceError", "result")}
OPTIONAL = {"view"}  # built with the viewer only


def public(name):
    return not name.startswith("_")


def stub_tree():
    return ast.parse(STUB.read_text())


def stub_names():
    """{name: node} of the stubs' public top-level classes and functions"""
    return {n.name: n for n in stub_tree().body
            if isinstance(n, (ast.ClassDef, ast.FunctionDef)) and public(n.name)}


def stub_members(cls):
    names = set()
    for n in cls.body:
        if isinstance(n, ast.FunctionDef) and public(n.name):
            names.add(n.name)
        if isinstance(n, ast.AnnAssign) and public(n.target.id):
            names.add(n.target.id)
    return names


def stub_params(fn):
    a = fn.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg != "self"]
    return names + ([a.kwarg.arg] if a.kwarg else [])


def runtime_members(cls):
    """the public names a class adds to its bases"""
    inherited = set().union(*(dir(b) for b in cls.__mro__[1:]))
    return {n for n in dir(cls) if public(n) and n not in inherited}


def native_params(obj):
    """parameter names from pybind11's signature line, "name(a: int, *, b: str = '') -> X";
    None for Python functions"""
    doc = (obj.__doc__ or "").split("\n", 1)[0]
    m = re.match(r"^\w+\((.*)\) ->", doc)
    if not m:
        return None
    names = [p.split(":")[0].strip() for p in re.split(r",\s*(?![^\[]*\])", m.group(1))]
    return [n.lstrip("*") for n in names if n not in ("self", "*")]


def test_the_stubs_are_shipped_next_to_the_module():
    folder = pathlib.Path(stance.__file__).parent
    assert STUB.is_file()
    assert (folder / "py.typed").is_file()
    assert any(folder.glob("_stance*.so"))


def test_every_public_name_is_in_the_stubs_and_every_stub_name_exists():
    stubs = stub_names()
    exported = set(stance.__all__)
    native = {n for n in dir(stance._stance) if public(n)}
    # the native names are all re-exported: a binding added without its export fails here
    assert native <= exported, sorted(native - exported)
    assert exported - set(stubs) == set(), "not in __init__.pyi"
    assert set(stubs) - exported == set(), "in __init__.pyi but not exported"
    missing = {n for n in exported if not hasattr(stance, n)} - OPTIONAL
    assert missing == set(), "in __all__ but not in the module"
    aliases = {t.id for n in stub_tree().body if isinstance(n, ast.Assign) for t in n.targets}
    assert aliases - {"__all__"} <= ALIASES


@pytest.mark.parametrize("name", sorted(n for n, v in stub_names().items()
                                        if isinstance(v, ast.ClassDef)))
def test_each_class_has_the_members_its_stub_lists(name):
    cls = getattr(stance, name)
    listed = stub_members(stub_names()[name])
    actual = runtime_members(cls) | {m for c, m in INSTANCE_ONLY if c == name}
    assert actual - listed == set(), f"{name}: members missing from __init__.pyi"
    assert listed - actual == set(), f"{name}: members in __init__.pyi that it lacks"


def callables():
    """(qualified name, runtime object, stub node) of every function and method"""
    for name, node in stub_names().items():
        if not hasattr(stance, name):
            continue
        obj = getattr(stance, name)
        if isinstance(node, ast.FunctionDef):
            yield name, obj, node
            continue
        for m in node.body:
            if isinstance(m, ast.FunctionDef) and public(m.name) and not any(
                    isinstance(d, ast.Name) and d.id == "property" or isinstance(d, ast.Attribute)
                    for d in m.decorator_list):
                yield f"{name}.{m.name}", getattr(obj, m.name), m


def test_functions_and_methods_take_the_parameters_their_stubs_name():
    checked = 0
    for qualified, obj, node in callables():
        params = native_params(obj)
        if params is None:  # written in Python: its own signature
            params = [p for p in inspect.signature(obj).parameters if p != "self"]
            if qualified == "run":  # run(path, duration, **load_args): load's keywords
                params = params[:2] + [p for p in native_params(stance.load) if p != "path"
                                       and p != "duration"]
        assert stub_params(node) == params, qualified
        checked += 1
    assert checked > 60  # every function and method of the stubs, not a few
