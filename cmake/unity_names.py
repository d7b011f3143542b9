#!/usr/bin/env python3
"""Finds file-local names that two source files of one unity-built target both define.

A unity build (cmake/unity.cmake) compiles a target's files several to one translation unit,
and which files share one depends on the NUMEN_WITH_* options (a file left out shifts the
batches): two files of one target that each define a name in an anonymous namespace or as a
file-level `static` are a redefinition error in some build, even when the default build puts
them apart. This check reads every file of every unity-built target and names each such pair,
whatever the options.

Usage: unity_names.py LIST
  LIST: lines "<target>\t<absolute source path>" (written by CMake at configure time).
Exit status: 0 none found; 1 names defined twice (each printed as file:line: name, target);
2 bad usage or an unreadable file.

What counts as a definition, at the top level of an anonymous namespace (or a file-level
`static`): a function (the name before its parameter list; two of one name clash unless their
parameter lists differ, as an overload set), a struct, class, union or enum, a variable or
constant, and an alias (`using X = ...`, `typedef`, `namespace X = ...`) or using-declaration
(`using a::X;`). Aliases and using-declarations of one thing may repeat (the same text, or one a
`::`-suffix of the other); of another thing, or beside a definition, they clash. Names in distinct
named namespaces do not meet. Test macros (TEST, TEST_F, ...) are not names. The reading is
lexical (comments and literals removed, braces counted), not a C++ parse.
"""
import re
import sys
from collections import defaultdict

MACROS = {"TEST", "TEST_F", "TEST_P", "TYPED_TEST", "TYPED_TEST_SUITE", "INSTANTIATE_TEST_SUITE_P",
          "TYPED_TEST_P", "REGISTER_TYPED_TEST_SUITE_P", "BENCHMARK", "BENCHMARK_MAIN",
          "PYBIND11_MODULE", "static_assert", "GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST"}
KEYWORDS = {"const", "constexpr", "inline", "static", "volatile", "unsigned", "signed", "auto",
            "return", "if", "for", "while", "switch", "sizeof", "decltype", "noexcept",
            "operator", "template", "typename", "extern", "thread_local", "mutable", "explicit",
            "friend", "virtual", "override", "final", "consteval", "constinit", "alignas"}


def strip(text):
    """The text with comments, string and character literals and preprocessor lines blanked
    (newlines kept, so that offsets give line numbers)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            # A preprocessor line (with its continuations).
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c == "/" and text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
            continue
        if c == "/" and text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if m:
                end = text.find(")" + m.group(1) + '"', i)
                end = n if end < 0 else end + len(m.group(1)) + 2
                out.append('""' + re.sub(r"[^\n]", " ", text[i + 2:end]))
                i = end
                continue
        if c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator: 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + re.sub(r"[^\n]", " ", text[i + 1:j]) + c)
            i = j + 1
            continue
        out.append(c)
        line_start = c == "\n" or (line_start and c in " \t")
        i += 1
    return "".join(out)


def items(text):
    """(start offset, head text, anonymous, enclosing namespaces) of each declaration at the top level of an anonymous
    namespace, and of each file-level declaration that starts with `static`."""
    found = []
    # A stack of what each open brace is: 'anon', 'ns' (a named namespace), or 'other'.
    stack = []
    names = []  # the enclosing namespaces' names
    start = 0  # where the current declaration at this level starts
    depth_paren = 0
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in "([":
            depth_paren += 1
        elif c in ")]":
            depth_paren = max(0, depth_paren - 1)
        elif c == "{" and depth_paren == 0:
            head = text[start:i]
            at_scope = all(s in ("anon", "ns") for s in stack)
            m = re.search(r"\bnamespace\s*([\w:]*)\s*$", head)
            if at_scope and m:
                stack.append("ns" if m.group(1) else "anon")
                names.append(m.group(1) or "(anonymous)")
                start = i + 1
            else:
                if at_scope and not re.search(r"=\s*$", head):
                    found.append((start, head, "anon" in stack, "::".join(names)))
                stack.append("other")
        elif c == "}" and depth_paren == 0:
            kind = stack.pop() if stack else "other"
            if kind in ("anon", "ns") and names:
                names.pop()
            if kind in ("anon", "ns") or all(s in ("anon", "ns") for s in stack):
                start = i + 1
        elif c == ";" and depth_paren == 0 and all(s in ("anon", "ns") for s in stack):
            head = text[start:i]
            if head.strip():
                found.append((start, head, "anon" in stack, "::".join(names)))
            start = i + 1
        i += 1
    return found


def declared(head):
    """(name, kind, signature) of a declaration's head, or None."""
    h = " ".join(head.split())
    h = re.sub(r"^(template\s*<.*?>\s*)+", "", h)
    h = re.sub(r"\[\[.*?\]\]\s*", "", h)
    if not h or h.startswith(("using namespace", "extern \"C\"")):
        return None
    # Aliases (of a namespace or a type) may be declared again as the same: one clashes only with
    # an alias of another thing, or with a definition.
    m = re.match(r"(namespace|using)\s+(\w+)\s*=\s*(.*)$", h)
    if m:
        return m.group(2), "alias", "= " + re.sub(r"\s+", "", m.group(3))
    m = re.match(r"using\s+(?:typename\s+)?((?:\w+::)+(\w+))\s*$", h)
    if m:
        # A using-declaration: the same one twice is allowed; beside a definition of its name,
        # it clashes.
        return m.group(2), "using", "= " + m.group(1)
    if re.match(r"using\s", h):
        return None
    m = re.match(r"typedef\s+(.*?)\b(\w+)\s*$", h)
    if m:
        return m.group(2), "alias", "= " + re.sub(r"\s+", "", m.group(1))
    m = re.match(r"(?:(?:static|inline|constexpr)\s+)*(?:struct|class|union|enum(?:\s+class|\s+struct)?)\s+(?:alignas\s*\(.*?\)\s*)?(\w+)", h)
    if m and "(" not in h.split(m.group(1), 1)[0]:
        rest = h[m.end():].strip()
        if not rest or rest.startswith((":", "final")) or "{" in rest:
            return m.group(1), "type", ""
    # A function: the identifier just before the first '(' at the top (not inside <...>).
    lt = 0
    for k, ch in enumerate(h):
        if ch == "<":
            lt += 1
        elif ch == ">":
            lt = max(0, lt - 1)
        elif ch == "=" and lt == 0:
            break  # a variable initialised by a call
        elif ch == "(" and lt == 0:
            m = re.search(r"(~?\w+)\s*$", h[:k])
            if not m or m.group(1) in KEYWORDS:
                return None
            name = m.group(1)
            if name in MACROS or re.fullmatch(r"[A-Z][A-Z0-9_]*", name) and name.isupper() and "_" in name:
                return None
            if re.search(r"\boperator\s*\S*$", h[:k]):
                return None
            params = h[k:]
            params = re.sub(r"\s*(const|noexcept|override|->.*)\s*$", "", params)
            # Parameter types only: drop names and default values.
            sig = re.sub(r"=[^,)]*", "", params)
            sig = re.sub(r"\b(\w+)\s*([,)])", lambda mm: mm.group(2) if mm.group(1) not in
                         {"int", "double", "float", "bool", "char", "long", "short", "unsigned", "size_t"}
                         else mm.group(1) + mm.group(2), sig)
            return name, "function", re.sub(r"\s+", "", sig)
    # A variable or constant: the identifier before '=', '{', '[' or the end.
    m = re.search(r"(\w+)\s*(?:\[[^\]]*\])?\s*(?:=.*)?$", h)
    if m and m.group(1) not in KEYWORDS and not h.startswith(("return", "friend")):
        return m.group(1), "variable", ""
    return None


def same_entity(a, b):
    """Whether two aliases' or using-declarations' targets ("= core::Vec3", "= numen::core::Vec3")
    may name one thing: equal, or one a `::`-suffix of the other (a lexical reading cannot know
    more; two of distinct last names are two things)."""
    a, b = a[2:], b[2:]
    return a == b or a.endswith("::" + b) or b.endswith("::" + a)


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[0] + "\nusage: unity_names.py LIST", file=sys.stderr)
        return 2
    targets = defaultdict(list)
    try:
        with open(argv[1], encoding="utf-8") as f:
            for line in f:
                line = line.rstrip("\n")
                if line:
                    target, path = line.split("\t", 1)
                    if path not in targets[target]:
                        targets[target].append(path)
    except (OSError, ValueError) as e:
        print(f"unity_names.py: {argv[1]}: {e}", file=sys.stderr)
        return 2
    clashes = 0
    files_read = 0
    for target, paths in sorted(targets.items()):
        names = defaultdict(list)  # name -> [(path, line, kind, signature)]
        for path in paths:
            try:
                with open(path, encoding="utf-8") as f:
                    raw = f.read()
            except OSError as e:
                print(f"unity_names.py: {path}: {e}", file=sys.stderr)
                return 2
            files_read += 1
            text = strip(raw)
            for start, head, anonymous, scope in items(text):
                if not anonymous and not re.match(r"\s*(?:template\s*<.*?>\s*)?static\b", head, re.S):
                    continue
                d = declared(head)
                if d is None:
                    continue
                offset = start + len(head) - len(head.lstrip())
                line = text.count("\n", 0, offset) + 1
                # Names in distinct named namespaces do not meet.
                qualified = re.sub(r"(^|::)\(anonymous\)", "", scope)
                names[(qualified + "::" if qualified else "") + d[0]].append((path, line, d[1], d[2]))
        for name, where in sorted(names.items()):
            paths_of = {w[0] for w in where}
            if len(paths_of) < 2:
                continue
            # Functions of distinct parameter lists in every file are an overload set; aliases
            # of one thing in every file are one alias.
            if all(w[2] in ("alias", "using") for w in where) and all(
                    same_entity(a[3], b[3]) for a in where for b in where):
                continue
            if all(w[2] == "function" for w in where):
                by_sig = defaultdict(set)
                for w in where:
                    by_sig[w[3]].add(w[0])
                if all(len(p) < 2 for p in by_sig.values()):
                    continue
            clashes += 1
            print(f"{target}: '{name}' is file-local in {len(paths_of)} files; in one unity "
                  f"translation unit it is defined twice (rename one, or share it from a header):")
            for w in where:
                print(f"  {w[0]}:{w[1]}: {w[2]} {name}{w[3] if w[2] in ('function', 'alias', 'using') else ''}")
    print(f"unity_names.py: {files_read} files of {len(targets)} targets read; "
          f"{clashes} name(s) file-local in more than one file of a target")
    return 1 if clashes else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
