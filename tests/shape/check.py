#!/usr/bin/env python3
"""The shape of the code, checked: what docs/architecture.md promises of it.

- no import circle between the module files of a crate (a file A uses B, through `crate::`,
  `super::`, `self::` or a child module's name, and B uses A, directly or through a chain); a
  name a module re-exports from a child counts as the child's;
- no file longer than MAX_LINES before its tests (the line of its first `#[cfg(test)]`);
- at most MAX_LIBRARY_PUB public items in the root library and MAX_BINARY_PUB in the node and
  the command line (`src/node/`, `src/cli/`), an item being a `pub` fn, struct, enum, trait,
  type, const, static, mod or use (struct fields are the messages' contract and not counted);
- at most MAX_FILES_NAMING_A_KIND files under `src/` naming KIND_NAMED (tests included): the
  other files reach a kind through `kind::Kind`.

Run from the repository's root: `python3 tests/shape/check.py`; it prints what it found and
exits 1 when a bound is broken.
"""
import os
import re
import sys
from collections import defaultdict

CRATES = ["src", "crates/solver/src", "crates/geometry/src", "crates/python/src"]
MAX_LINES = 700
MAX_LIBRARY_PUB = 150
# At most this many files under src/ name a message kind's request type: its own module, the
# kinds' table, the answerer of its kind and the messages' definitions (docs/architecture.md).
MAX_FILES_NAMING_A_KIND = 5
KIND_NAMED = "PoseCandidateSet"
MAX_BINARY_PUB = 10
BINARY = ("src/node/", "src/cli/", "src/main.rs")
PUB_ITEM = re.compile(
    r"^\s*pub (?:fn|struct|enum|trait|type|const|static|mod|use|async fn|unsafe fn)\b", re.M
)


def module_files(root):
    """Module path (a tuple) to file, for every `.rs` file under `root` (the library's: a
    `main.rs` beside a `lib.rs` is the root of another crate, the binary)."""
    files = {}
    for d, _, names in os.walk(root):
        for name in names:
            if name == "main.rs" and "lib.rs" in names:
                continue
            if name.endswith(".rs"):
                path = os.path.join(d, name)
                parts = os.path.relpath(path, root)[:-3].split(os.sep)
                if parts[-1] in ("mod", "lib", "main"):
                    parts = parts[:-1]
                files[tuple(parts)] = path
    return files


def before_tests(text):
    """The text of a file before its first `#[cfg(test)]`."""
    i = text.find("#[cfg(test)]")
    return text if i < 0 else text[:i]


def reexports(files):
    """(module, name) to the child module a `pub use child::name` takes it from, or
    'external' for a name re-exported from another crate."""
    out = {}
    pattern = re.compile(r"pub(?:\([\w:]+\))?\s+use\s+(?:self::)?(\w+)::(\{[^}]*\}|\w+)")
    for module, path in files.items():
        text = open(path, encoding="utf-8").read()
        for m in pattern.finditer(text):
            child = module + (m.group(1),)
            names = re.findall(r"\w+", m.group(2))
            if child in files:
                out.update({(module, n): child for n in names})
            elif m.group(1) not in ("crate", "super", "self"):
                out.update({(module, n): "external" for n in names})
        # `pub use other_crate as name;`
        for m in re.finditer(r"pub(?:\([\w:]+\))?\s+use\s+(\w+)\s+as\s+(\w+)\s*;", text):
            if (module + (m.group(1),)) not in files:
                out[(module, m.group(2))] = "external"
    return out


def resolve(module, segments, files, reexported):
    """The module file a path used in `module` lands in, or None (another crate)."""
    head, rest = segments[0], segments[1:]
    if head == "crate":
        base = []
    else:
        base = list(module)
        while segments and segments[0] in ("super", "self"):
            if segments[0] == "super":
                base = base[:-1]
            segments = segments[1:]
        rest = segments
    full = base + list(rest)
    for n in range(len(full), -1, -1):
        prefix = tuple(full[:n])
        if prefix in files:
            if n < len(full) and (prefix, full[n]) in reexported:
                target = reexported[(prefix, full[n])]
                return None if target == "external" else target
            return prefix
    return None


def uses(files):
    """Module to the set of modules whose items it uses (outside its tests)."""
    reexported = reexports(files)
    edges = defaultdict(set)
    path_use = re.compile(r"\b(crate|super|self)((?:::\w+)+)")
    for module, path in files.items():
        text = before_tests(open(path, encoding="utf-8").read())
        text = re.sub(r"//[^\n]*", "", text).replace("$crate", "crate")
        # `a::{b, c::d}` becomes `a::b a::c::d`, nested groups from the inside out.
        for _ in range(3):
            text = re.sub(
                r"((?:crate|super|self)(?:::\w+)*)::\{([^{}]*)\}",
                lambda m: " ".join(
                    m.group(1) + "::" + i.strip() for i in m.group(2).split(",") if i.strip()
                ),
                text,
            )
        for m in re.finditer(r"(?<![:\w])(\w+)::", text):
            child = module + (m.group(1),)
            if child in files:
                edges[module].add(child)
        for m in path_use.finditer(text):
            segments = [m.group(1)] + m.group(2).split("::")[1:]
            target = resolve(module, segments, files, reexported)
            if target is not None and target != module:
                edges[module].add(target)
    return edges


def circles(edges, nodes):
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(component)

    for v in nodes:
        if v not in index:
            visit(v)
    return found


def main():
    broken = []
    for root in CRATES:
        files = module_files(root)
        edges = uses(files)
        for component in circles(edges, list(files)):
            names = ", ".join("/".join(m) or "<root>" for m in sorted(component))
            broken.append(f"{root}: import circle among {names}")
        for path in files.values():
            lines = before_tests(open(path, encoding="utf-8").read()).count("\n")
            if lines > MAX_LINES:
                broken.append(f"{path}: {lines} lines before its tests (at most {MAX_LINES})")
    library = binary = 0
    for path in [*module_files("src").values(), "src/main.rs"]:
        n = len(PUB_ITEM.findall(open(path, encoding="utf-8").read()))
        if path.startswith(BINARY):
            binary += n
        else:
            library += n
    print(f"public items: {library} in the library (at most {MAX_LIBRARY_PUB}), "
          f"{binary} in the node and the command line (at most {MAX_BINARY_PUB})")
    if library > MAX_LIBRARY_PUB:
        broken.append(f"{library} public items in the library")
    if binary > MAX_BINARY_PUB:
        broken.append(f"{binary} public items in src/node and src/cli")
    naming = sorted(p for p in module_files("src").values()
                    if re.search(rf"\b{KIND_NAMED}\b", open(p, encoding="utf-8").read()))
    print(f"files naming {KIND_NAMED}: {len(naming)} (at most {MAX_FILES_NAMING_A_KIND})")
    if len(naming) > MAX_FILES_NAMING_A_KIND:
        broken.append(f"{len(naming)} files under src/ name {KIND_NAMED}: {', '.join(naming)}")
    for b in broken:
        print(b)
    print("the shape holds" if not broken else f"{len(broken)} bounds broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
