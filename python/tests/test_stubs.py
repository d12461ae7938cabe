"""help() shows a docstring for every function, and python/relume.pyi declares every function and
Session method of the module with the same parameters as the module's own signatures."""
import ast
import re

import relume
from conftest import SOURCE_DIR


def module_functions():
    return {name: obj for name, obj in vars(relume).items()
            if callable(obj) and not isinstance(obj, type) and not name.startswith("_")}


def session_methods():
    return {name: obj for name, obj in vars(relume.Session).items() if callable(obj) and not name.startswith("_")}


def signature(doc):
    """Parameters (name, default text or None, keyword-only) from pybind11's first docstring line."""
    line = doc.splitlines()[0]
    inside = line[line.index("(") + 1:line.rindex(") ->")]
    params, keyword_only, depth, current = [], False, 0, ""
    for ch in inside + ",":
        depth += ch in "([{" and 1 or ch in ")]}" and -1 or 0
        if ch == "," and depth == 0:
            part = current.strip()
            current = ""
            if part == "*":
                keyword_only = True
            elif part and not part.startswith("self"):
                name = re.match(r"\w+", part).group(0)
                default = part.split(" = ", 1)[1] if " = " in part else None
                params.append((name, default, keyword_only))
        else:
            current += ch
    return params


def stub_signature(node):
    args = node.args
    positional = [a for a in args.args if a.arg != "self"]
    defaults = [None] * (len(positional) - len(args.defaults)) + [ast.unparse(d) for d in args.defaults]
    params = [(a.arg, d, False) for a, d in zip(positional, defaults)]
    params += [(a.arg, ast.unparse(d) if d is not None else None, True) for a, d in zip(args.kwonlyargs,
                                                                                     args.kw_defaults)]
    return params


def stubs():
    tree = ast.parse((SOURCE_DIR / "python/relume.pyi").read_text())
    functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    session = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Session")
    methods = {n.name: n for n in session.body if isinstance(n, ast.FunctionDef) and not n.decorator_list}
    properties = {n.name for n in session.body if isinstance(n, ast.FunctionDef) and n.decorator_list}
    return functions, methods, properties


def same_default(module_text, stub_text):
    if module_text is None or stub_text is None:
        return module_text == stub_text
    return module_text == stub_text or ast.literal_eval(module_text) == ast.literal_eval(stub_text)


def test_every_function_has_a_docstring_beyond_its_signature():
    properties = {name: obj for name, obj in vars(relume.Session).items() if isinstance(obj, property)}
    for name, obj in {**module_functions(), **session_methods(), **properties}.items():
        lines = [line for line in (obj.__doc__ or "").splitlines() if line.strip()]
        text = " ".join(lines if isinstance(obj, property) else lines[1:])  # a property has no signature line
        assert len(text) > (15 if isinstance(obj, property) else 60), name


def test_the_stubs_declare_what_the_module_has():
    functions, methods, properties = stubs()
    assert properties == {name for name, obj in vars(relume.Session).items() if isinstance(obj, property)}
    for table, stub in ((module_functions(), functions), (session_methods(), methods)):
        assert set(table) == set(stub) - {"__init__"}, set(table) ^ (set(stub) - {"__init__"})
        for name, obj in table.items():
            module, declared = signature(obj.__doc__), stub_signature(stub[name])
            assert [(n, k) for n, _, k in module] == [(n, k) for n, _, k in declared], name
            for (param, a, _), (_, b, _) in zip(module, declared):
                assert same_default(a, b), f"{name}({param}): module default {a}, stub {b}"
