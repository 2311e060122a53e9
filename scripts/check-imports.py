#!/usr/bin/env python3
"""Fails on a loop of imports between the files of a crate.

A file imports another when it names it in a `use` or in a path that starts at `crate::`,
`super::` or `self::`. The crate root (lib.rs, main.rs) is the table of contents and is left
out; a parent's `mod` and `pub use` of its own children are declarations, not imports. Each
loop kept is named in KEPT with its reason.

    scripts/check-imports.py [crates/NAME ...]
"""
import glob
import os
import re
import sys

# (crate, the loop's files sorted, why it is kept)
KEPT = []

USE = re.compile(r'^\s*(pub(\([^)]*\))?\s+)?use\s+([^;]+);', re.M)
PATH = re.compile(r'\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)')


def modules(src):
    """Module path (a tuple) of every file under src."""
    found = {}
    for f in glob.glob(os.path.join(src, '**', '*.rs'), recursive=True):
        rel = os.path.relpath(f, src)[:-3].split(os.sep)
        if rel[-1] == 'mod':
            rel = rel[:-1]
        if rel in (['lib'], ['main']):
            continue
        if rel[0] == 'bin':
            continue
        found[tuple(rel)] = f
    return found


def expand(tree):
    """`a::{b, c::{d, e}}` into a::b, a::c::d, a::c::e."""
    tree = re.sub(r'\s+', '', tree)
    depth, start = 0, tree.find('{')
    if start < 0:
        return [tree]
    prefix, body = tree[:start], tree[start + 1:tree.rfind('}')]
    parts, cur = [], ''
    for ch in body:
        depth += ch == '{'
        depth -= ch == '}'
        if ch == ',' and depth == 0:
            parts.append(cur)
            cur = ''
        else:
            cur += ch
    parts.append(cur)
    return [p for part in parts if part for p in expand(prefix + part)]


def strip_comments(text):
    text = re.sub(r'/\*.*?\*/', '', text, flags=re.S)
    return re.sub(r'//[^\n]*', '', text)


def target(mod, path, mods):
    """The module file a path starting at crate/super/self names, if any."""
    segs = [s for s in path.split('::') if s]
    here = list(mod)
    is_dir = mods.get(mod, '').endswith('mod.rs')
    if segs[0] == 'crate':
        base, segs = [], segs[1:]
    elif segs[0] == 'self':
        base, segs = here, segs[1:]
    else:
        base = here if is_dir else here[:-1]
        while segs and segs[0] == 'super':
            base, segs = base[:-1], segs[1:]
    best = None
    for n in range(len(segs), 0, -1):
        cand = tuple(base + segs[:n])
        if cand in mods:
            best = cand
            break
    if best is None and tuple(base) in mods:
        best = tuple(base)
    return best


def edges(mods):
    graph = {m: set() for m in mods}
    for mod, f in mods.items():
        text = strip_comments(open(f, encoding='utf-8').read())
        text = re.sub(r'#\[cfg\(test\)\]\s*mod\s+tests\s*\{.*', '', text, flags=re.S)
        paths = []
        for m in USE.finditer(text):
            is_pub = bool(m.group(1))
            for p in expand(m.group(3)):
                p = p.split(' as ')[0]
                first = p.split('::')[0]
                if first not in ('crate', 'super', 'self'):
                    # 2018 paths: a child of this module, else an external crate
                    child = mod + (first,)
                    if child in mods:
                        if is_pub:
                            continue
                        p = 'self::' + p
                    else:
                        continue
                paths.append(p)
        paths += [m.group(1) for m in PATH.finditer(text)]
        for p in paths:
            t = target(mod, p, mods)
            if t is None or t == mod:
                continue
            graph[mod].add(t)
    return graph


def loops(graph):
    """Strongly connected components of more than one file (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    return out


def self_test():
    """The check finds a loop it is shown, through `use`, `super::` and a path, and no other."""
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        os.makedirs(os.path.join(d, 'src', 'm'))
        files = {
            'lib.rs': 'mod a;\nmod b;\nmod c;\nmod m;\npub use a::A;\n',
            'a.rs': 'use crate::b::B;\npub struct A;\n',
            'b.rs': 'pub struct B;\nfn f(n: crate::m::n::N) {}\n',
            'c.rs': 'use crate::a::A;\n',
            'm/mod.rs': 'mod n;\npub use n::N;\npub fn g() {}\n',
            'm/n.rs': 'use super::g;\npub struct N(crate::a::A);\n',
        }
        for name, text in files.items():
            with open(os.path.join(d, 'src', name), 'w') as f:
                f.write(text)
        found = [sorted('::'.join(m) for m in comp) for comp in loops(edges(modules(os.path.join(d, 'src'))))]
        assert found == [['a', 'b', 'm::n']], found


def main():
    self_test()
    root = os.path.join(os.path.dirname(__file__), '..')
    crates = sys.argv[1:] or sorted(glob.glob(os.path.join(root, 'crates', '*')))
    bad = 0
    for crate in crates:
        src = os.path.join(crate, 'src')
        if not os.path.isdir(src):
            continue
        name = os.path.basename(os.path.normpath(crate))
        graph = edges(modules(src))
        for comp in loops(graph):
            names = sorted('::'.join(m) for m in comp)
            if any(k[0] == name and sorted(k[1]) == names for k in KEPT):
                continue
            detail = '; '.join(f"{'::'.join(a)} -> {', '.join('::'.join(b) for b in sorted(graph[a]) if b in comp)}"
                               for a in comp)
            print(f'check-imports: a loop of imports in {name}: {detail}', file=sys.stderr)
            bad = 1
    return bad


if __name__ == '__main__':
    sys.exit(main())
