"""python/ddoc.pyi describes the module: the same public names, the same class members."""
import ast
import pathlib

import ddoc

STUB = pathlib.Path(__file__).resolve().parents[2] / "python/ddoc.pyi"


def stub_names():
    tree = ast.parse(STUB.read_text())
    names = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AnnAssign, ast.Assign)):
                    if isinstance(item, ast.FunctionDef):
                        members.add(item.name)
                    elif isinstance(item, ast.AnnAssign):
                        members.add(item.target.id)
                    else:
                        members.update(t.id for t in item.targets)
            names[node.name] = {m for m in members if not m.startswith("_")}
        elif isinstance(node, ast.FunctionDef):
            names[node.name] = None
        elif isinstance(node, ast.AnnAssign):  # module constants (type aliases are Assign)
            names[node.target.id] = None
    return names


def runtime_members(obj):
    if isinstance(obj, type) and issubclass(obj, BaseException):  # the class's own attributes
        return {m for m in vars(obj) if not m.startswith("_")}
    members = {m for m in dir(obj) if not m.startswith("_")}
    if hasattr(obj, "__members__"):  # pybind11 enums: values plus name/value
        return set(obj.__members__)
    return members


def test_stub_matches_module():
    stub = stub_names()
    public = {n for n in dir(ddoc) if not n.startswith("_")}
    hopper_only = {"run_hopper", "RunFailed", "HAVE_RENDER"}  # with the MuJoCo application only
    assert set(stub) - hopper_only == public - hopper_only
    if hasattr(ddoc, "run_hopper"):
        assert hopper_only <= public
    for name, members in stub.items():
        if members is None or not hasattr(ddoc, name):
            continue
        runtime = runtime_members(getattr(ddoc, name))
        # Inherited members are declared on the base class in the stub.
        for base in getattr(ddoc, name).__mro__[1:]:
            if base.__name__ in stub and stub[base.__name__]:
                members = members | stub[base.__name__]
        assert members == runtime, (name, members ^ runtime)
