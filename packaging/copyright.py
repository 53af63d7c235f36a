#!/usr/bin/env python3
"""Write the Debian copyright file (DEP-5) of the drivectl package from Cargo's own data.

    packaging/copyright.py --target aarch64-unknown-linux-gnu --out target/packaging/copyright

What is listed: every crate compiled into /usr/bin/drivectl for that target, found by walking
the resolved dependency graph of `cargo metadata --filter-platform TARGET` from drivectl along
normal dependencies (proc macros included: their output is in the binary; build and dev
dependencies left out: nothing of them is). For each crate: its licence expression (Cargo.toml's
`license`), the copyright lines of the licence files it ships (or its authors when it ships
none), and which files those were. Then one stand-alone paragraph per licence: a pointer into
/usr/share/common-licenses where Debian has the text, otherwise the text itself, as most of the
crates that use that licence ship it (without their copyright lines), or from
packaging/licenses/ for a licence that no crate ships a text of. A licence with no text
anywhere, or an expression this script cannot translate, fails the build with a message.
"""

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import textwrap

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# SPDX identifier -> file in /usr/share/common-licenses (Debian policy 12.5: refer, do not copy).
COMMON = {
    "Apache-2.0": "Apache-2.0",
    "MPL-2.0": "MPL-2.0",
    "GPL-2.0-only": "GPL-2",
    "GPL-2.0-or-later": "GPL-2",
    "GPL-3.0-only": "GPL-3",
    "GPL-3.0-or-later": "GPL-3",
    "LGPL-2.1-only": "LGPL-2.1",
    "LGPL-2.1-or-later": "LGPL-2.1",
    "LGPL-3.0-only": "LGPL-3",
    "LGPL-3.0-or-later": "LGPL-3",
    "CC0-1.0": "CC0-1.0",
}

# How a licence text is recognised: the first entry whose phrases are all in it (case ignored;
# the Boost and Unicode licences have the MIT licence's first words, so they come first).
KNOWN_TEXTS = [
    ("Apache-2.0", ["apache license", "version 2.0, january 2004"]),
    ("ISC", ["permission to use, copy, modify, and", "distribute this software for any purpose"]),
    ("BSL-1.0", ["boost software license"]),
    ("Unicode-3.0", ["unicode license v3"]),
    ("MIT", ["permission is hereby granted, free of charge"]),
    ("MPL-2.0", ["mozilla public license", "2.0"]),
    ("Unlicense", ["free and unencumbered software released into the public domain"]),
    ("GPL-3.0-only", ["gnu general public license", "version 3, 29 june 2007"]),
    ("BSD-3-Clause", ["redistribution and use in source and binary forms", "neither the name"]),
    ("BSD-2-Clause", ["redistribution and use in source and binary forms"]),
    ("EPL-2.0", ["eclipse public license - v 2.0"]),
]

LICENCE_FILE = re.compile(r"^(licen[cs]e|copying|copyright|unlicense|notice)", re.IGNORECASE)
# A copyright notice: "Copyright (c) 2014 Alex Crichton", "Copyright © 1991-2024 Unicode, Inc.",
# "(c) 2016 …" (a year after it: the Apache licence's clause 4 (c) is no notice); not the templates of the Apache appendix ("Copyright [yyyy] [name …]").
NOTICE = re.compile(r"^\s*(copyright\s*(\(c\)|©)?\s*\S|(\(c\)|©)\s*\d)", re.IGNORECASE)
TEMPLATE = re.compile(r"[\[{<]\s*(yyyy|year|name)|copyright (notice|holders?|owner|license|and permission)"
                      r"|copyright law|copyright \(c\) <|^\s*copyright\s*$", re.IGNORECASE)
# In a workspace crate's own sources (its licence differs from the workspace's): a notice
# anywhere on a line, up to its full stop.
INLINE_NOTICE = re.compile(r"Copyright (\(c\)|©) \d{4}[^.\n]*", re.IGNORECASE)


def fail(message):
    print(f"packaging/copyright.py: {message}", file=sys.stderr)
    sys.exit(1)


def identify(text):
    low = " ".join(text.lower().split())
    for ident, phrases in KNOWN_TEXTS:
        if all(p in low for p in phrases):
            return ident
    return None


def is_notice(line):
    return bool(NOTICE.match(line)) and not TEMPLATE.search(line) and len(line) < 200


def without_notices(text):
    """The licence's terms: the text without its copyright lines and surrounding blank lines."""
    lines = [line.rstrip() for line in text.splitlines() if not is_notice(line)]
    while lines and not lines[0].strip():
        lines.pop(0)
    while lines and not lines[-1].strip():
        lines.pop()
    return "\n".join(lines)


def read(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return f.read()


def spdx_ids(expression):
    return [t for t in re.split(r"[\s()/]+", expression) if t and t not in ("OR", "AND", "WITH")]


def dep5_expression(expression):
    """SPDX to DEP-5: `or`/`and` in lower case, and DEP-5's comma where SPDX has parentheses."""

    def flat(e):
        if "(" in e or ")" in e:
            fail(f"cannot translate the licence expression {expression!r}: add the case to dep5_expression")
        e = re.sub(r"\s*/\s*", " OR ", e)
        return re.sub(r"\b(OR|AND|WITH)\b", lambda m: m.group(1).lower(), e)

    grouped = re.fullmatch(r"\((.+)\) AND (.+)", expression.strip())
    if grouped:
        return f"{flat(grouped.group(1))}, and {flat(grouped.group(2))}"
    return flat(expression.strip())


def wrapped(text):
    return textwrap.wrap(text, width=90, break_long_words=False, break_on_hyphens=False)


def field(lines):
    """A multi-line DEP-5 field value: first line after the name, the rest indented, blank
    lines as " ."."""
    out = []
    for i, line in enumerate(lines):
        if i == 0:
            out.append(line)
        else:
            out.append(" " + line if line.strip() else " .")
    return "\n".join(out)


def crate_graph(target, package):
    meta = json.loads(
        subprocess.run(
            ["cargo", "metadata", "--format-version", "1", "--locked", "--filter-platform", target],
            cwd=ROOT,
            check=True,
            stdout=subprocess.PIPE,
        ).stdout
    )
    packages = {p["id"]: p for p in meta["packages"]}
    nodes = {n["id"]: n for n in meta["resolve"]["nodes"]}
    roots = [p["id"] for p in meta["packages"] if p["name"] == package and p["source"] is None]
    if len(roots) != 1:
        fail(f"no workspace package {package!r} in cargo metadata")
    seen, todo = set(), roots[:]
    while todo:
        pid = todo.pop()
        if pid in seen:
            continue
        seen.add(pid)
        for dep in nodes[pid]["deps"]:
            if any(k["kind"] is None for k in dep["dep_kinds"]):
                todo.append(dep["pkg"])
    return meta, [packages[p] for p in sorted(seen, key=lambda p: (packages[p]["name"], packages[p]["version"]))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--target", required=True, help="Rust target triple, e.g. x86_64-unknown-linux-gnu")
    ap.add_argument("--package", default="drivectl")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()

    meta, crates = crate_graph(args.target, args.package)
    workspace_root = meta["workspace_root"]
    root_pkg = next(p for p in crates if p["name"] == args.package)
    own_licence = root_pkg["license"]

    files_paragraphs = []
    used_ids = collections.OrderedDict()
    # licence id -> list of (crate name, text without notices), from the crates' own files
    texts = collections.defaultdict(list)
    own_crates = []

    for p in crates:
        expression = p["license"]
        crate_dir = os.path.dirname(p["manifest_path"])
        if not expression:
            if p.get("license_file"):
                fail(f"{p['name']} {p['version']} has only a license-file: add that case to this script")
            fail(f"{p['name']} {p['version']} declares no licence")
        for ident in spdx_ids(expression):
            used_ids.setdefault(ident, None)
        if p["source"] is None:
            # A workspace crate: under the workspace's licence, or a paragraph of its own.
            if expression == own_licence:
                own_crates.append(p["name"])
                continue
            notices = set()
            for dirpath, dirnames, filenames in os.walk(crate_dir):
                dirnames[:] = [d for d in dirnames if d not in ("target", "tests", "benches")]
                for name in filenames:
                    if name.endswith((".rs", ".proto", ".toml")):
                        for m in INLINE_NOTICE.finditer(read(os.path.join(dirpath, name))):
                            notices.add(m.group(0).strip())
            rel = os.path.relpath(crate_dir, workspace_root)
            files_paragraphs.append(
                (
                    f"{rel}/*",
                    ["the drivebus authors"] + sorted(notices),
                    dep5_expression(expression),
                    f"The workspace crate {p['name']}, compiled into /usr/bin/drivectl; its"
                    f" manifest says why its licence differs from the workspace's.",
                )
            )
            continue
        shipped = sorted(f for f in os.listdir(crate_dir) if LICENCE_FILE.match(f) and os.path.isfile(os.path.join(crate_dir, f)))
        notices = []
        for name in shipped:
            text = read(os.path.join(crate_dir, name))
            for line in text.splitlines():
                line = line.strip().strip("*#/ ").strip()
                if is_notice(line) and line not in notices:
                    notices.append(line)
            ident = identify(text)
            if ident is not None and ident in spdx_ids(expression):
                texts[ident].append((f"{p['name']} {p['version']}", without_notices(text)))
        if not notices:
            notices = p["authors"] or [f"the {p['name']} authors"]
        comment = (
            f"The crate {p['name']} {p['version']} from crates.io, compiled into /usr/bin/drivectl."
            + (f" Licence files it ships: {', '.join(shipped)}." if shipped else " It ships no licence file.")
        )
        files_paragraphs.append((f"rust-crates/{p['name']}-{p['version']}/*", notices, dep5_expression(expression), comment))

    third_party = sum(1 for p in crates if p["source"] is not None)
    out = [
        "Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/",
        "Upstream-Name: drivebus",
        field(
            [
                f"Comment: Generated by packaging/copyright.py from `cargo metadata` for {args.target}.",
                f"/usr/bin/drivectl is built from the drivebus workspace (Files: *) and from the {third_party}",
                "crates listed below; rust-crates/NAME-VERSION/ names a crate's source as published",
                "on crates.io.",
            ]
        ),
        "",
        "Files: *",
        "Copyright: the drivebus authors",
        f"License: {dep5_expression(own_licence)}",
        field(wrapped("Comment: The drivebus workspace crates " + ", ".join(sorted(own_crates)) + ".")),
    ]
    for files, notices, licence, comment in files_paragraphs:
        out += ["", f"Files: {files}", "Copyright: " + field(notices), f"License: {licence}", field(wrapped("Comment: " + comment))]

    for ident in used_ids:
        out.append("")
        if ident in COMMON:
            path = f"/usr/share/common-licenses/{COMMON[ident]}"
            out.append(field([f"License: {ident}", f"On Debian systems the full text of this licence is in {path}."]))
            continue
        candidates = texts.get(ident, [])
        if candidates:
            counts = collections.Counter(" ".join(t.split()) for _, t in candidates)
            best = max(counts.items(), key=lambda kv: kv[1])[0]
            source, text = next((c, t) for c, t in candidates if " ".join(t.split()) == best)
            others = counts[best] - 1
            note = (
                f"The text as the crate {source} ships it"
                + (f" (and {others} more crates with the same words)" if others else "")
                + "; each crate's copyright holders are in its Files paragraph."
            )
        else:
            path = os.path.join(HERE, "licenses", ident)
            if not os.path.isfile(path):
                fail(
                    f"no text of the licence {ident}: no crate that uses it ships one and"
                    f" packaging/licenses/{ident} does not exist; add the licence's text there"
                )
            text = read(path).strip("\n")
            note = f"No crate ships this text; it is packaging/licenses/{ident}."
        out.append(field([f"License: {ident}"] + text.splitlines()))
        out.append(field(wrapped("Comment: " + note)))

    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")
    print(
        f"copyright: {args.out}: {len(crates)} crates ({len(own_crates)} of the workspace),"
        f" licences {', '.join(used_ids)}"
    )


if __name__ == "__main__":
    main()
