#!/usr/bin/env python3
"""test_cli_doc.py PHKS CLI_MD MESHES - the examples of docs/cli.md run
with the built tool, their standard output compared with the doc.

An example is an indented block whose lines start with `$ phks ...`; the
lines under a command, up to the next `$` or the block's end, are what it
prints to stdout (stderr is not compared). The markup, as docs/cli.md's
"Examples" paragraph states it:

- a line `...` stands for any number of lines, and a line ending in ` ...`
  for any line that starts with the rest;
- `<!-- not checked: REASON -->` on the line before a block leaves the
  block out (examples that take minutes);
- `<!-- mask: REGEX -->` before a block replaces what REGEX matches by `#`
  in both the doc's lines and the output (numbers of the machine: times,
  paths), and may be given more than once.

Everything else is compared exactly, but for a number printed with 15
or more significant digits (JSON's doubles), which matches within a
relative 1e-12: scores depend only on the library and the BLAS, and
OpenBLAS picks its kernels by processor, so its sums may round otherwise
in the last bits on another machine (docs/guide.md, "Determinism"). The commands run in the order of the doc
in one scratch folder, where psb/, scans/ and shared/data/meshes lead to
the shared meshes, so a later example may use an earlier one's files.
Exit status 77 (skipped) without the shared meshes."""
import os
import re
import shlex
import subprocess
import sys
import tempfile


def blocks(text):
    """(first line number, lines, masks, reason left out or None) of each
    example block."""
    lines = text.split("\n")
    out, i = [], 0
    while i < len(lines):
        if not lines[i].startswith("    $ "):
            i += 1
            continue
        start, body = i, []
        while i < len(lines) and (lines[i].startswith("    ") or
                                  (lines[i] == "" and i + 1 < len(lines) and
                                   lines[i + 1].startswith("    "))):
            body.append(lines[i][4:])
            i += 1
        masks, skip, j = [], None, start - 1
        while j >= 0 and lines[j].startswith("<!--"):
            m = re.match(r"<!-- not checked: (.*) -->$", lines[j])
            skip = m.group(1) if m else skip
            m = re.match(r"<!-- mask: (.*) -->$", lines[j])
            if m:
                masks.append(m.group(1))
            j -= 1
        out.append((start + 1, body, masks, skip))
    return out


def commands(body):
    """(command, expected lines) of a block; `\\` continues a command."""
    out = []
    for line in body:
        if line.startswith("$ ") and not (out and out[-1][0].endswith("\\")):
            out.append([line[2:], []])
        elif out and out[-1][0].endswith("\\"):
            out[-1][0] = out[-1][0][:-1] + " " + line.strip()
        else:
            out[-1][1].append(line)
    for c in out:  # blank lines at the end belong to the prose
        while c[1] and c[1][-1] == "":
            c[1].pop()
    return out


NUMBER = re.compile(r"-?[0-9]+\.[0-9]+(?:[eE][-+]?[0-9]+)?")


def long_number(text):
    """Whether the number's mantissa has 15 or more significant digits."""
    digits = re.sub(r"[^0-9]", "", re.split(r"[eE]", text)[0])
    return len(digits.lstrip("0")) >= 15


def same_line(expected, got):
    """Whether got is expected, its long numbers within a relative 1e-12."""
    want, have = NUMBER.split(expected), NUMBER.split(got)
    if want != have:
        return False
    for a, b in zip(NUMBER.findall(expected), NUMBER.findall(got)):
        if a == b:
            continue
        x, y = float(a), float(b)
        if not (long_number(a) and long_number(b) and
                abs(x - y) <= 1e-12 * max(abs(x), abs(y))):
            return False
    return True


def matches(expected, got):
    """Whether the lines got match expected, with its `...` lines."""
    if not expected:
        return not got
    head = expected[0]
    if head == "...":
        return any(matches(expected[1:], got[k:])
                   for k in range(len(got) + 1))
    if not got:
        return False
    if head.endswith(" ...") and got[0].startswith(head[:-4]):
        return matches(expected[1:], got[1:])
    return same_line(head, got[0]) and matches(expected[1:], got[1:])


def masked(lines, masks):
    for m in masks:
        lines = [re.sub(m, "#", line) for line in lines]
    return [line.rstrip() for line in lines]


def run(phks, command, where):
    argv = shlex.split(command, comments=True)
    assert argv[0] == "phks", command
    r = subprocess.run([phks] + argv[1:], cwd=where, capture_output=True,
                       text=True, timeout=600)
    return r.returncode, r.stdout.split("\n")[:-1], r.stderr


def main():
    phks, doc, meshes = (os.path.abspath(a) for a in sys.argv[1:4])
    if not os.path.isfile(os.path.join(meshes, "MANIFEST.tsv")):
        print("SKIP: the shared meshes (%s) are absent; docs/cli.md's "
              "examples read them" % meshes)
        return 77
    with open(doc) as f:
        found = blocks(f.read())
    failures = checked = 0
    with tempfile.TemporaryDirectory() as where:
        for name in ("psb", "scans"):
            os.symlink(os.path.join(meshes, name), os.path.join(where, name))
        os.makedirs(os.path.join(where, "shared", "data"))
        os.symlink(meshes, os.path.join(where, "shared", "data", "meshes"))
        for line, body, masks, skip in found:
            for command, expected in commands(body):
                if skip is not None:
                    print("cli.md:%d: not checked (%s): $ %s" %
                          (line, skip, command))
                    continue
                rc, got, err = run(phks, command, where)
                checked += 1
                want = masked(expected, masks)
                if rc == 0 and matches(want, masked(got, masks)):
                    print("cli.md:%d: ok: $ %s" % (line, command))
                    continue
                failures += 1
                print("cli.md:%d: FAIL (exit status %d): $ %s\n--- the doc\n"
                      "%s\n--- the output\n%s\n--- stderr\n%s" %
                      (line, rc, command, "\n".join(expected),
                       "\n".join(got), err))
    print("%d examples checked, %d failed" % (checked, failures))
    return 1 if failures or not checked else 0


if __name__ == "__main__":
    sys.exit(main())
