#!/usr/bin/env python3
"""File-level import circles inside each crate: files that import each other, directly or
through others (every strongly connected component of more than one file of a crate's module
tree, its integration tests' (tests/it/main.rs) included; `#[cfg(test)]` modules are ignored). Prints each; exits 1 on any circle not in KNOWN.

Usage: python3 tests/circles.py [REPOSITORY]   (run by .ci/run)"""
import os, re, sys

ROOT = sys.argv[1] if len(sys.argv) > 1 else "."

# Circles kept on purpose, each with its reason. A new circle fails; a fixed one must leave here.
KNOWN: set = set()

def strip(src):
    # remove comments and string/char literals (roughly)
    out, i, n = [], 0, len(src)
    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i); i = n if j < 0 else j
        elif src.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if src.startswith("/*", i): depth += 1; i += 2
                elif src.startswith("*/", i): depth -= 1; i += 2
                else: i += 1
        elif c == 'r' and re.match(r'r#*"', src[i:i+10]) and (i == 0 or not (src[i-1].isalnum() or src[i-1] == '_')):
            m = re.match(r'r(#*)"', src[i:]); hashes = m.group(1)
            end = src.find('"' + hashes, i + len(m.group(0)))
            i = n if end < 0 else end + 1 + len(hashes); out.append('""')
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == '\\' else 1
            i = j + 1; out.append('""')
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", src[i:i+4] + "  "):
            m = re.match(r"'(\\[^']*|[^\\'])'", src[i:]); i += len(m.group(0)) if m else 1
        else:
            out.append(c); i += 1
    return "".join(out)

def drop_cfg_test(src):
    # remove `#[cfg(test)] mod name { ... }` blocks
    while True:
        m = re.search(r'#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{', src)
        if not m: return src
        i, depth = m.end(), 1
        while i < len(src) and depth:
            if src[i] == '{': depth += 1
            elif src[i] == '}': depth -= 1
            i += 1
        src = src[:m.start()] + src[i:]

class Crate:
    def __init__(self, name, root_file):
        self.name = name
        self.files = {}     # module path tuple -> file
        self.src = {}       # file -> stripped source
        self.walk((), root_file)

    def walk(self, path, f):
        self.files[path] = f
        s = drop_cfg_test(strip(open(f).read()))
        self.src[f] = s
        base = os.path.dirname(f)
        stem = os.path.splitext(os.path.basename(f))[0]
        d = base if stem in ("lib", "main", "mod") else os.path.join(base, stem)
        for m in re.finditer(r'(?:#\[path\s*=\s*""\]\s*)?(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;', s):
            name = m.group(1)
            for cand in (os.path.join(d, name + ".rs"), os.path.join(d, name, "mod.rs")):
                if os.path.exists(cand):
                    self.walk(path + (name,), cand); break

    def defines(self, f, name):
        return re.search(r'\b(fn|struct|enum|trait|const|static|type|union|macro_rules!)\s+' + re.escape(name) + r'\b', self.src[f]) is not None

def use_paths(s):
    """Expand every `use` tree into full paths (lists of segments); plus inline crate::/super:: paths."""
    paths = []
    for m in re.finditer(r'\buse\s+([^;]+);', s):
        paths += expand(re.sub(r'\s+', '', m.group(1)))
    for m in re.finditer(r'(?<![\w:])((?:crate|super|self)(?:::\w+)+)', s):
        paths.append(m.group(1).split("::"))
    return paths

def expand(tree):
    # a::b::{c, d::{e, f}, g as h}
    tree = re.sub(r'\bas\w+', '', tree.replace(" as ", " as"))
    i = tree.find("{")
    if i < 0:
        return [[p for p in tree.split("::") if p]]
    prefix = [p for p in tree[:i].split("::") if p]
    inner = tree[i+1:tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur); cur = ""
        else:
            depth += ch == "{"; depth -= ch == "}"; cur += ch
    if cur: parts.append(cur)
    out = []
    for p in parts:
        for e in expand(p):
            out.append(prefix + [x for x in e if x != "self"] if e != ["self"] else prefix)
    return out

def resolve(crate, here, segs, seen=None):
    """The file that defines what `segs` names, seen from module path `here`."""
    seen = seen or set()
    if not segs: return None
    if segs[0] == "crate": mod, rest = (), segs[1:]
    elif segs[0] == "self": mod, rest = here, segs[1:]
    elif segs[0] == "super":
        mod, rest = here, segs
        while rest and rest[0] == "super":
            mod, rest = mod[:-1], rest[1:]
    else: return None
    while rest and mod + (rest[0],) in crate.files:
        mod, rest = mod + (rest[0],), rest[1:]
    f = crate.files[mod]
    if not rest or rest[0] == "*": return f
    name = rest[0]
    if crate.defines(f, name) or (f, name) in seen: return f
    seen.add((f, name))
    for p in use_paths_cached(crate, f):
        if p and p[-1] == name and p[0] in ("crate", "self", "super"):
            g = resolve(crate, mod, p, seen)
            if g: return g
    return f

_cache = {}
def use_paths_cached(crate, f):
    if f not in _cache: _cache[f] = [p for p in use_paths(crate.src[f])]
    return _cache[f]

def crate_graph(crate):
    mod_of = {f: p for p, f in crate.files.items()}
    g = {f: set() for f in crate.src}
    for f, s in crate.src.items():
        for p in use_paths_cached(crate, f):
            t = resolve(crate, mod_of[f], p)
            if t and t != f:
                # a parent module declaring/re-exporting its child is not an import back
                g[f].add(t)
    return g

def sccs(g):
    index, low, stack, on, out, i = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)
    def visit(v):
        index[v] = low[v] = i[0]; i[0] += 1; stack.append(v); on.add(v)
        for w in g[v]:
            if w not in index: visit(w); low[v] = min(low[v], low[w])
            elif w in on: low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop(); on.discard(w); comp.append(w)
                if w == v: break
            out.append(comp)
    for v in g:
        if v not in index: visit(v)
    return [c for c in out if len(c) > 1]

def main():
    bad = 0
    seen = set()
    roots = []
    for d in sorted(os.listdir(os.path.join(ROOT, "crates"))):
        # The library, the program, and the one integration-test binary (tests/it/).
        for r in ("src/lib.rs", "src/main.rs", "tests/it/main.rs"):
            p = os.path.join(ROOT, "crates", d, r)
            if os.path.exists(p): roots.append((d + ":" + r, p))
    for r in ("src/lib.rs", "tests/it/main.rs"):
        p = os.path.join(ROOT, r)
        if os.path.exists(p): roots.append(("rmd-rt:" + r if r != "src/lib.rs" else "rmd-rt", p))
    for name, p in roots:
        c = Crate(name, p)
        for comp in sccs(crate_graph(c)):
            line = name + ": " + " <-> ".join(sorted(os.path.relpath(f, os.path.dirname(p)) for f in comp))
            seen.add(line)
            if line in KNOWN:
                print(line + "  (known, see KNOWN)")
            else:
                bad += 1
                print(line + "  NEW")
    for line in sorted(KNOWN - seen):
        bad += 1
        print(line + "  FIXED: remove it from KNOWN in tests/circles.py")
    print(f"{bad} new or stale circle(s), {len(seen & KNOWN)} known")
    return 1 if bad else 0

if __name__ == "__main__":
    sys.exit(main())
