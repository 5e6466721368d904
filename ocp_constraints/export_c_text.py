"""C text of an export: the header, C API wrappers, example program and build files.

Pure string builders used by :mod:`ocp_constraints.export` to write the export folder;
they read an :class:`~ocp_constraints.export.ExportReport` and return C, Make or CMake text.
"""
from __future__ import annotations

import re
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from .export import Block, Entry, ExportedFunction, ExportReport

C_FLAGS = ("-Wall", "-Wextra", "-Werror", "-O2")


def _mark_unused_parameters(code: str) -> str:
    """Add ``(void)p;`` for each parameter of each multi-line function definition.

    CasADi's generated functions take ``iw``, ``w`` and ``mem`` whether they use them or
    not, which ``-Wextra`` reports as unused parameters.
    """
    pattern = re.compile(r"^((?:static |CASADI_SYMBOL_EXPORT )[^;{}\n]*?\w+\(([^()]*)\) \{)$", re.M)

    def mark(m: re.Match) -> str:
        names = [re.findall(r"(\w+)\s*$", p)[0] for p in m.group(2).split(",") if p.strip() not in ("", "void")]
        return m.group(1) + ("\n  " + " ".join(f"(void){n};" for n in names) if names else "")

    return pattern.sub(mark, code)


def _macros(prefix: str, block: Block) -> list[str]:
    """Index macro per entry, ``<PREFIX>_<BLOCK>_<KEY>``; made unique if two keys collide."""
    out: list[str] = []
    for e in block.entries:
        m = re.sub(r"\W", "_", f"{prefix}_{block.name}_{e.key}").upper()
        out.append(m if m not in out else f"{m}_{len(out)}")
    return out


def _c_params(report: ExportReport, fn: ExportedFunction) -> str:
    P = report.prefix.upper()
    out = []
    for b in fn.inputs:
        out.append("double t" if b == "t" else f"const double {b}[{P}_{b.upper()}_SIZE]")
    out += [f"double {b}[{P}_{b.upper()}_SIZE]" for b in fn.outputs]
    return ", ".join(out)


def _header(report: ExportReport) -> str:
    p, P = report.prefix, report.prefix.upper()
    params = ", ".join(f"{k} = {float(v)!r}" for k, v in report.parameters.items()) or "none"
    L = [f"/* {p}_constraints.h: constraint functions of the scene '{report.scene}', exported by ocp_constraints.",
         " *",
         " * Generated C (CasADi " + ca.__version__ + "); build with the Makefile or CMakeLists.txt beside this file.",
         f" * Scene parameters (SI units, compiled in): {params}.",
         " *",
         " * Conventions: vectors are components in the fixed right-handed basis E1, E2, E3; body",
         " * basis e_i = Q E_i. Speeds are u = (vbar, omega) per body. A scalar constraint reads",
         " * pi = f . v_C + h . omega + e = 0 (v_C: velocity of the joint's material point X_C), and",
         " * its multiplier lambda gives F_c = lambda f acting at X_C and M_c = lambda h (paper eq. 26).",
         " * Units of lambda assume f dimensionless for a constraint with a force part (pi in m/s,",
         " * lambda in N) and h dimensionless otherwise (pi in rad/s, lambda in N m).",
         " *",
         " * Every function takes dense double arrays laid out as documented below, returns 0 on",
         " * success, keeps no state and is thread-safe. Arguments a function does not depend on",
         " * (t, inputs) are not part of its signature.",
         " */",
         f"#ifndef {P}_CONSTRAINTS_H", f"#define {P}_CONSTRAINTS_H", "",
         "#ifdef __cplusplus", 'extern "C" {', "#endif", "",
         f'#define {P}_SCENE "{report.scene}"', ""]
    for b in report.blocks.values():
        if b.name == "t":
            continue
        L.append(f"/* {b.name}[{b.size}]: {b.title} */")
        L.append(f"#define {P}_{b.name.upper()}_SIZE {b.size}")
        macros = _macros(p, b)
        width = max(len(m) for m in macros)
        for i, (m, e) in enumerate(zip(macros, b.entries)):
            L.append(f"#define {m:<{width}} {i:>3}  /* {e.name} [{e.unit}]: {e.description} */")
        L.append(f"extern const char* const {p}_{b.name}_names[{P}_{b.name.upper()}_SIZE];")
        L.append("")
    for fn in report.functions:
        L.append(f"/* {fn.name}: {fn.summary}.")
        L.append(f" *   inputs: {', '.join(fn.inputs)}; outputs: {', '.join(fn.outputs)}.")
        missing = [x for x in ("t", "inputs") if x in report.blocks and x not in fn.inputs]
        if missing:
            L.append(f" *   Not an argument (does not depend on it): {', '.join(missing)}.")
        L.append(f" *   Cost: {fn.n_operations} arithmetic operations ({fn.n_instructions} CasADi instructions). */")
        L.append(f"int {fn.name}({_c_params(report, fn)});")
        L.append("")
    L += ["#ifdef __cplusplus", "}", "#endif", f"#endif /* {P}_CONSTRAINTS_H */", ""]
    return "\n".join(L)


def _c_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _wrappers(report: ExportReport) -> str:
    p, P = report.prefix, report.prefix.upper()
    L = [f"/* {p}_constraints.c: the plain C API of {p}_constraints.h over the CasADi functions in",
         f" * {p}_casadi.c (work arrays on the stack: reentrant). Generated by ocp_constraints. */",
         f'#include "{p}_casadi.h"', f'#include "{p}_constraints.h"', ""]
    for b in report.blocks.values():
        if b.name != "t":
            names = ", ".join(_c_string(e.name) for e in b.entries)
            L.append(f"const char* const {p}_{b.name}_names[{P}_{b.name.upper()}_SIZE] = {{{names}}};")
    L.append("")
    for fn in report.functions:
        c = fn.casadi_name
        L += [f"int {fn.name}({_c_params(report, fn)}) {{",
              f"  const casadi_real* arg[{c}_SZ_ARG + 1];", f"  casadi_real* res[{c}_SZ_RES + 1];",
              f"  casadi_int iw[{c}_SZ_IW + 1];", f"  casadi_real w[{c}_SZ_W + 1];"]
        L += [f"  arg[{i}] = {'&t' if b == 't' else b};" for i, b in enumerate(fn.inputs)]
        L += [f"  res[{i}] = {b};" for i, b in enumerate(fn.outputs)]
        L += [f"  return {c}(arg, res, iw, w, 0);", "}", ""]
    return "\n".join(L)


def _c_array(values, entries: list[Entry]) -> str:
    return "\n".join(f"  {float(v)!r},  /* {e.name} [{e.unit}] */" for v, e in zip(np.ravel(values), entries))


def _example(report: ExportReport) -> str:
    p, P = report.prefix, report.prefix.upper()
    L = [f"/* {p}_example.c: calls each function of {p}_constraints.h on a sample state and prints",
         " * one line per output entry: <function> <output> <index> <name> <value>.",
         " * Sample: the scene's consistent initial state at t = 0; udot from the forward dynamics;",
         " * the loads use the multipliers computed here. Generated by ocp_constraints. */",
         "#include <stdio.h>", f'#include "{p}_constraints.h"', ""]
    used = {b for fn in report.functions for b in fn.inputs}  # an unused static const is a warning
    for b in ("q", "u", "udot", "inputs"):
        if b in used:
            L += [f"static const double {b}[{P}_{b.upper()}_SIZE] = {{",
                  _c_array(report.sample[b], report.blocks[b].entries), "};"]
    if "t" in used:
        L.append(f"static const double t = {float(np.ravel(report.sample['t'])[0])!r};  /* [s] */")
    L += ["",
          "static void print_block(const char* function, const char* output, const double* v, int n,",
          "                        const char* const* names) {",
          "  int i;",
          "  for (i = 0; i < n; ++i) printf(\"%s %s %d %s %.17g\\n\", function, output, i, names[i], v[i]);",
          "}", "", "int main(void) {"]
    outputs = {b for fn in report.functions for b in fn.outputs}
    L += [f"  double {b}[{P}_{b.upper()}_SIZE];" for b in report.blocks if b in outputs]
    L.append(f'  printf("# scene %s\\n", {P}_SCENE);')
    order = sorted(report.functions, key=lambda f: f.name.endswith("_loads"))  # loads use lam
    for fn in order:
        call_args = list(fn.inputs) + list(fn.outputs)
        L.append(f"  if ({fn.name}({', '.join(call_args)}) != 0) {{")
        L.append(f'    fprintf(stderr, "{fn.name} failed\\n");')
        L += ["    return 1;", "  }"]
        for b in fn.outputs:
            L.append(f'  print_block("{fn.name}", "{b}", {b}, {P}_{b.upper()}_SIZE, {p}_{b}_names);')
    L += ["  return 0;", "}", ""]
    return "\n".join(L)


def _makefile(report: ExportReport) -> str:
    p, lib = report.prefix, report.library_name
    return "\n".join([
        f"# Builds {lib} and {p}_example with the system C compiler (generated by ocp_constraints).",
        "#   make          build both", "#   make run      build and run the example", "",
        f"CFLAGS = {' '.join(C_FLAGS)}", "LDLIBS = -lm", "",
        f"all: {lib} {p}_example", "",
        f"{lib}: {p}_casadi.c {p}_constraints.c {p}_casadi.h {p}_constraints.h",
        f"\t$(CC) $(CFLAGS) -fPIC -shared -o $@ {p}_casadi.c {p}_constraints.c $(LDLIBS)", "",
        f"{p}_example: {p}_example.c {p}_constraints.h {lib}",
        f"\t$(CC) $(CFLAGS) -o $@ {p}_example.c -L. -l{p}_constraints -Wl,-rpath,'$$ORIGIN' $(LDLIBS)", "",
        f"run: {p}_example", f"\t./{p}_example", "",
        "clean:", f"\trm -f {lib} {p}_example", "", ".PHONY: all run clean", ""])


def _cmakelists(report: ExportReport) -> str:
    p = report.prefix
    flags = " ".join(C_FLAGS)
    return "\n".join([
        "# Builds the shared library and the example (generated by ocp_constraints).",
        "cmake_minimum_required(VERSION 3.10)", f"project({p}_constraints C)", "",
        f"add_library({p}_constraints SHARED {p}_casadi.c {p}_constraints.c)",
        f"add_executable({p}_example {p}_example.c)",
        f"target_link_libraries({p}_example PRIVATE {p}_constraints)",
        'if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")',
        f"  target_compile_options({p}_constraints PRIVATE {flags})",
        f"  target_compile_options({p}_example PRIVATE {flags})", "endif()",
        "if(UNIX)", f"  target_link_libraries({p}_constraints PRIVATE m)", "endif()", ""])


def _kernel_size(code: str, casadi_name: str) -> tuple[int, int]:
    m = re.search(rf"/\* {re.escape(casadi_name)}:.*?\*/\nstatic int \w+\(.*?\n\}}\n", code, re.S)
    text = m.group(0) if m else ""
    return len(text.encode()), text.count("\n")

