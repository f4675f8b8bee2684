#!/usr/bin/env python3
"""The architecture check of `make lint`: prt-baker's module import graph has no cycle, no
layer imports a layer above it, and no source file outgrows the size a reader can hold.

Usage: scripts/check-layers.py baker/src LAYER,LAYER,... (lowest first)
           [--max-lines FILE=N ...] [--max-function-lines FOLDER=N ...]
[IMPORTS_V=-v lists every file's imports]. --max-lines holds FILE (under baker/src) to N
lines, tighter than the 700 of every file; --max-function-lines holds every function of the
files under FOLDER to N lines, from its `fn` line to its closing brace. A module's imports are its `use` paths and `crate::`/`super::` paths
outside comments and strings, resolved to the file that defines them; a folder's mod.rs
depends on a child it names. The cycle check leaves out test modules (a test may use its
parent); the layer check does not: no code, test or not, imports a layer above its own.
Exits 1 with the offenders listed.
"""
import argparse, os, re, sys, collections
def limit(text):
    path, _, n = text.rpartition("=")
    return path, int(n)
cli = argparse.ArgumentParser(description="prt-baker's import graph, layers and sizes")
cli.add_argument("root")
cli.add_argument("layers", nargs="?")
cli.add_argument("--max-lines", type=limit, action="append", default=[], metavar="FILE=N")
cli.add_argument("--max-function-lines", type=limit, action="append", default=[],
                 metavar="FOLDER=N")
opts = cli.parse_args()
root = opts.root
layers = opts.layers.split(",") if opts.layers else None
files = {}
for d, _, fs in os.walk(root):
    for f in fs:
        if f.endswith(".rs"):
            p = os.path.join(d, f)
            rel = os.path.relpath(p, root)[:-3]
            parts = rel.split(os.sep)
            if parts[-1] == "mod": parts = parts[:-1]
            if parts in (["lib"], ["main"]): parts = [] if parts == ["lib"] else ["<main>"]
            files[tuple(parts)] = p
def resolve(path):
    for n in range(len(path), -1, -1):
        if tuple(path[:n]) in files: return tuple(path[:n])
    return None
def strip(src):
    out=[]
    for line in src.split("\n"):
        s=line.strip()
        if s.startswith("//"): continue
        out.append(line)
    src="\n".join(out)
    src=re.sub(r'"(\\.|[^"\\])*"','""',src)
    return src
def without_tests(src):
    # drop #[cfg(test)] mod tests { ... } roughly: cut from '#[cfg(test)]\nmod tests' to end
    m=re.search(r'#\[cfg\(test\)\]\s*mod tests', src)
    return src[:m.start()] if m else src
edges=collections.defaultdict(set)  # without test modules: the cycle check
all_edges=collections.defaultdict(set)  # with them: the layer check
def expand_use(body):
    # expand brace groups: a::{b, c::{d}} -> a::b, a::c::d; drop renames (`x as y`)
    body=re.sub(r'\s+as\s+\w+','',body)
    body=re.sub(r'\s+','',body)
    res=[]
    def rec(prefix, s):
        # split top-level commas
        depth=0; cur=''; items=[]
        for ch in s:
            if ch=='{': depth+=1
            if ch=='}': depth-=1
            if ch==',' and depth==0: items.append(cur); cur=''
            else: cur+=ch
        if cur: items.append(cur)
        for it in items:
            if '{' in it:
                i=it.index('{'); rec(prefix+it[:i], it[i+1:-1])
            else: res.append(prefix+it)
    rec('', body)
    return res
def imports(mod, p, src):
    """The modules of the crate that `src`, the source of `mod` (file `p`), uses."""
    paths=[]
    for m in re.finditer(r'\buse\s+([^;]+);', src):
        paths.extend(expand_use(m.group(1)))
    for m in re.finditer(r'(?<![\w:])((?:crate|super|self)(?:::\w+)+)', src):
        paths.append(m.group(1))
    is_modrs = p.endswith("mod.rs") or p.endswith("lib.rs")
    for cm in re.finditer(r'^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;', src, re.M):
        child = cm.group(1)
        if re.search(r'(?<![\w:])' + child + r'::', src):
            paths.append('self::' + child if is_modrs else 'CHILD::' + child)
    found=set()
    for u in paths:
        segs=u.split("::")
        if segs[0]=='crate': base=[]; segs=segs[1:]
        elif segs[0]=='CHILD': base=list(mod); segs=segs[1:]
        elif segs[0] in ('super','self'):
            base=list(mod)
            while segs and segs[0] in ('super','self'):
                if segs[0]=='super': base=base[:-1]
                segs=segs[1:]
        else: continue
        tgt=resolve(base+segs)
        if tgt is None or tgt==mod: continue
        if mod and tgt==mod[:len(tgt)] and len(tgt)<len(mod) and tgt!=(): 
            pass
        if tgt==(): continue  # crate root re-exports
        found.add(tgt)
    return found
for mod, p in files.items():
    src=strip(open(p).read())
    edges[mod]=imports(mod, p, without_tests(src))
    all_edges[mod]=imports(mod, p, src)
# SCCs (Tarjan)
idx={}; low={}; st=[]; on=set(); sccs=[]; c=[0]
sys.setrecursionlimit(10000)
def sc(v):
    idx[v]=low[v]=c[0]; c[0]+=1; st.append(v); on.add(v)
    for w in edges.get(v,()):
        if w not in idx: sc(w); low[v]=min(low[v],low[w])
        elif w in on: low[v]=min(low[v],idx[w])
    if low[v]==idx[v]:
        comp=[]
        while True:
            w=st.pop(); on.discard(w); comp.append(w)
            if w==v: break
        sccs.append(comp)
for v in files:
    if v not in idx: sc(v)
cyc=[s for s in sccs if len(s)>1]
name=lambda m: "/".join(m) or "lib"
print(f"files: {len(files)}  cycles: {len(cyc)}")
for s in cyc: print("  cycle:", " ".join(sorted(name(m) for m in s)))
if layers:
    rank={l:i for i,l in enumerate(layers)}
    up=[]
    for a,ts in all_edges.items():
        for b in ts:
            la=a[0] if a else None; lb=b[0]
            if la in rank and lb in rank and rank[lb]>rank[la]: up.append((name(a),name(b)))
    print(f"upward imports: {len(up)}")
    for a,b in sorted(up): print(f"  {a} -> {b}")
    # A folder outside the list would escape the order: every top-level module is a layer.
    unlisted = sorted({m[0] for m in files if m and m[0] not in rank and m != ("<main>",)})
    for m in unlisted: print(f"  {m}: not in the layer list")
MAX_LINES = 700
long_files = [(p, n) for p in files.values() if (n := sum(1 for _ in open(p))) > MAX_LINES]
for p, n in long_files:
    print(f"  {p}: {n} lines (at most {MAX_LINES})")
main = os.path.join(root, "main.rs")
main_lines = sum(1 for _ in open(main)) if os.path.exists(main) else 0
if main_lines > 200:
    print(f"  {main}: {main_lines} lines (main.rs parses, dispatches and maps errors: at most 200)")
too_long = []
for rel, n in opts.max_lines:
    lines = sum(1 for _ in open(os.path.join(root, rel)))
    if lines > n: too_long.append(f"  {os.path.join(root, rel)}: {lines} lines (at most {n})")
FN = re.compile(r'^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+)?(?:async\s+)?(?:unsafe\s+)?fn\s+(\w+)')
def code_lines(path):
    """The file's lines with comments, strings and character literals blanked."""
    out = []; in_block = False
    for line in open(path).read().split("\n"):
        code = []; i = 0
        while i < len(line):
            if in_block:
                j = line.find("*/", i)
                if j < 0: break
                in_block = False; i = j + 2; continue
            if line.startswith("//", i): break
            if line.startswith("/*", i): in_block = True; i += 2; continue
            if line[i] == '"':
                j = i + 1
                while j < len(line) and line[j] != '"': j += 2 if line[j] == "\\" else 1
                code.append('""'); i = j + 1; continue
            m = re.match(r"'(\\.|[^\\'])'", line[i:])
            if m: code.append("' '"); i += m.end(); continue
            code.append(line[i]); i += 1
        out.append("".join(code))
    return out
def functions(path):
    """(name, first line, lines) of each function with a body in `path`."""
    code = code_lines(path); found = []
    for k, line in enumerate(code):
        m = FN.match(line)
        if not m: continue
        depth = 0; nest = 0; opened = False; end = None
        for e in range(k, len(code)):
            for ch in code[e]:
                if ch in "([": nest += 1
                elif ch in ")]": nest -= 1
                elif ch == "{": depth += 1; opened = True
                elif ch == "}":
                    depth -= 1
                    if opened and depth == 0: end = e; break
                elif ch == ";" and not opened and nest == 0: end = -1; break
            if end is not None: break
        if end is not None and end >= 0: found.append((m.group(1), k + 1, end - k + 1))
    return found
for folder, n in opts.max_function_lines:
    for d, _, fs in os.walk(os.path.join(root, folder)):
        for f in sorted(fs):
            if not f.endswith(".rs"): continue
            p = os.path.join(d, f)
            for fn, line, lines in functions(p):
                if lines > n: too_long.append(f"  {p}:{line}: fn {fn} is {lines} lines (at most {n})")
for t in too_long: print(t)
failed = bool(cyc) or bool(layers and (up or unlisted)) or bool(long_files) or main_lines > 200
failed = failed or bool(too_long)
if "-v" in os.environ.get("IMPORTS_V",""):
    for a in sorted(edges): print(name(a),"->",", ".join(sorted(name(b) for b in edges[a])))
sys.exit(1 if failed else 0)
