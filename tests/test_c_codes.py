"""runtime/c/swpm_codes.h: the code catalogue for C (severity and meaning of every code a reader reports),
generated from swpm_usd/format/errors.py: in sync with it, complete for the C reader, and compiling clean
under an engine's strict flags as C99 and C++11."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from swpm_usd.format.errors import _ENTRIES, C_READER_CODES, render_c_header

RUNTIME = Path(__file__).resolve().parents[1] / "runtime" / "c"
STRICT = ["-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wsign-conversion", "-Wshadow", "-Wcast-align"]
STRICT_C = ["-std=c99", *STRICT, "-Wstrict-prototypes", "-Wmissing-prototypes", "-Werror"]
STRICT_CXX = ["-x", "c++", "-std=c++11", *STRICT, "-Wzero-as-null-pointer-constant", "-Wmissing-declarations"]

LOOKUP = r"""#include <stdio.h>
#include "swpm_reader.h"
#include "swpm_codes.h"
int main(int argc, char **argv) {
    int i;
    for (i = 1; i < argc; i++) {
        const swpm_code_info *c = swpm_code_lookup(argv[i]);
        printf("%s\t%s\t%s\n", argv[i], c ? c->severity : "-", c ? c->meaning : "-");
    }
    return swpm_code_lookup(NULL) != NULL;
}
"""


def test_the_header_is_generated_from_the_catalogue():
    assert (RUNTIME / "swpm_codes.h").read_text() == render_c_header(), (
        "regenerate: python -m swpm_usd.format.errors --c > runtime/c/swpm_codes.h"
    )


def test_every_code_the_c_reader_can_return_is_listed():
    listed = {e.code for e in [*_ENTRIES, *C_READER_CODES]}
    returned = set(re.findall(r'"(SWPM_[A-Z0-9_]+)"', (RUNTIME / "swpm_reader.h").read_text()))
    assert returned and returned <= listed, sorted(returned - listed)
    assert {e.code for e in C_READER_CODES} == {c for c in returned if c.startswith("SWPM_READER_")}


def test_lookup_gives_each_code_s_severity_and_meaning_in_c_and_cxx(tmp_path):
    cc, cxx = shutil.which("cc"), shutil.which("c++")
    if cc is None or cxx is None:
        pytest.fail("no C / C++ compiler (cc, c++): the C reader's tests need both (README, Drawing from C)")
    src = tmp_path / "lookup.c"
    src.write_text(LOOKUP)
    unused = tmp_path / "unused.c"  # (a unit that includes the header and uses nothing of it: no warning)
    unused.write_text('#include "swpm_codes.h"\nint f(void);\nint f(void) { return 1; }\n')
    inc = ["-I", str(RUNTIME)]
    for cmd in (
        [cc, *STRICT_C, "-O2", *inc, "-o", str(tmp_path / "lookup"), str(src)],
        [cxx, *STRICT_CXX, "-Werror", "-O2", *inc, "-o", str(tmp_path / "lookup_cxx"), str(src)],
        [cc, *STRICT_C, "-O2", *inc, "-c", "-o", str(tmp_path / "unused.o"), str(unused)],
        [cxx, *STRICT_CXX, "-Werror", "-O2", *inc, "-c", "-o", str(tmp_path / "unused_cxx.o"), str(unused)],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True)
        assert proc.returncode == 0 and proc.stderr == "", (cmd, proc.stderr)
    entries = [*_ENTRIES, *C_READER_CODES]
    codes = [e.code for e in entries] + ["SWPM_NOT_A_CODE", "swpm_header_bad_magic"]
    expected = "".join(f"{e.code}\t{e.severity}\t{e.meaning}\n" for e in entries)
    expected += "SWPM_NOT_A_CODE\t-\t-\nswpm_header_bad_magic\t-\t-\n"
    for exe in ("lookup", "lookup_cxx"):
        proc = subprocess.run([str(tmp_path / exe), *codes], capture_output=True, text=True)
        assert proc.returncode == 0 and proc.stdout == expected
