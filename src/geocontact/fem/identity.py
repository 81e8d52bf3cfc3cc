"""When an FE result may be reused: one identity for the cache, the checkpoint and ``--resume``.

An FE run is decided by its inputs (material, force history, mesh preset and the force its mesh
is sized for, load steps per segment, Newton tolerance, volumetric treatment), by the FE engine's
source code and by the libraries that compute it (gmsh meshes, scikit-fem assembles, scipy
factorises, numpy does the rest). :class:`FeRunIdentity` holds all of them; its ``key()`` names
a campaign's cache entry, signs a checkpoint and is written to ``summary.json`` (``identity``),
and :func:`finished_run` is the one test of whether a result directory may stand in for a run::

    identity = FeRunIdentity.of(material, forces, "coarse", steps_per_segment=6)
    result = finished_run(directory, identity)   # FemResult, or None: run it again

What does not change the numbers is left out: whether ParaView fields are written, progress
bars, a campaign label, the output path.
"""

from __future__ import annotations

import ast
import csv
import functools
import hashlib
import json
import math
import sys
from dataclasses import dataclass, replace
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..grain.force_history import validate_forces
from ..grain.hertz import incipient_yield
from ..grain.material import Material
from .mesh import CONTACT_RADIUS_LIMIT
from .result import (
    CURVE_COLUMNS,
    TOLERANCE,
    FemResult,
)
from .settings import FeSettings, resolved_step_control

SCHEMA = "geocontact.fe-identity/1"
_SETTINGS = frozenset(FeSettings.names())
# A grain whose analytic first yield is at the contact edge (grain.hertz: friction angle above the
# critical one) has its FE first yield located by elastic solves (fem.run._Run._locate_first_yield),
# no longer extrapolated from the last elastic step, and with the yield ratio on the surface at the
# contact edge recovered from outside the contact (fem.solver.ContactSolver.edge_surface_ratio):
# recorded, so its earlier runs are not reused.
EDGE_FIRST_YIELD = "located by elastic solves, with the surface at the contact edge"
# The distributions whose versions decide an FE result (importlib.metadata names).
LIBRARIES = ("gmsh", "scikit-fem", "scipy", "numpy")
# The sources that decide an FE result besides its inputs: a change to any of them (a new Fp
# detector, a solver fix) invalidates earlier results even when the version string is unchanged.
# fem/checkpoint.py restores the state a resumed run goes on from. Named as modules of the package;
# what is hashed is their code (``code_fingerprint``), not where they live nor their comments.
FE_SOURCES = ("fem.checkpoint", "fem.facet_contact", "fem.finite_strain", "fem.mesh",
              "fem.plasticity", "fem.result", "fem.run", "fem.solver",
              "grain.force_history", "grain.hertz", "grain.material", "fem.roundoff",
              "fem.settings", "fem.state", "fem.linear_algebra", "fem.contact_outputs")

# Older FE sources whose finished runs the current sources reproduce bit for bit, by the hash of
# the current sources: {current: {older: why}}. An entry is made only for a change that cannot
# alter a run that finished under the older code (it acts only where that code gave up with a
# ConvergenceError, or only for a new opt-in input recorded in the identity when not at its
# default) and after finished runs of the older code were run again and compared
# (scripts/reproduce_fe_runs.py). Such a run is reused as the same run (``equivalent_run``); its
# record keeps the hash it was made with. Any other change of the sources leaves the entry
# behind with the old hash, and the older runs are stale again.
_NAN_ITERATE = ("a Newton iterate with a non-finite residual (finite strain: an element turned "
                "inside out) gives up before the linear solve instead of one solve later (its "
                "NaN right-hand side gave a NaN step, which gave up)")
_DENSE_RULE = ("the opt-in mesh rule 'contact-dense' added (fem/mesh.py; recorded in the identity "
               "as mesh_rule): the 'yield' and 'contact' meshes are the same arrays")
_CODE_ONLY = ("the FE hash reads the sources' code (their syntax trees without docstrings and "
              "import statements), not their file names, comments or docstrings: the package's "
              "modules were moved (material, hertz, force_history to grain, resolution "
              "to fem.roundoff, io to files) and their comments edited, with every syntax tree the "
              "same as at 209c6c5f6f7c038c (checked with this function on both trees)")
# fem/compiled.py is not among FE_SOURCES; its code is in a compiled run's identity
# (``compiled_code_hash``). Its finite-strain factoriser changed (issue 36, fe-solver) from
# CHOLMOD's simplicial LDL^T to its supernodal LL^T on OpenBLAS, with Newton steps by CG
# preconditioned with a reused factorisation (``reuse_factor``): a run's steps, cut-backs and
# Newton iterations as before, its states within the Newton tolerance of the earlier ones (the
# approach within 4e-8 at the first steps' absolute tolerance, 1e-9 after, on the weak grain's
# coarse run: scripts/compare_factor_reuse.py), not bit for bit, so the kernels="compiled" runs
# made before are stale ("made by other compiled kernels").
_COMPILED_KERNELS = ("the opt-in compiled finite-strain kernels added (kernels='compiled', "
                     "fem/compiled.py; recorded in the identity as kernels): fem.run._solver "
                     "builds the numpy path's solvers as before")
_EDGE_YIELD = ("the FE first yield of a grain whose analytic first yield is at the contact edge "
               "(friction angle above the critical one; recorded in the identity as first_yield) "
               "located by elastic solves between the last elastic and the first plastic step "
               "(fem.run._Run._locate_first_yield): the runs of every other grain are computed "
               "and summarised as before")
REPRODUCED_FE_CODE: dict[str, dict[str, str]] = {
    "07275231518417f5": {
        "f7594263f80ad0d4": _COMPILED_KERNELS,
        "209c6c5f6f7c038c": _COMPILED_KERNELS + "; " + _CODE_ONLY,
        "00df7dcdec639962": _COMPILED_KERNELS + "; " + _CODE_ONLY + "; " + _DENSE_RULE,
        "0fb388b18c5a441f": _COMPILED_KERNELS + "; " + _CODE_ONLY + "; " + _DENSE_RULE + "; "
                            + _NAN_ITERATE,
        "51d4fb8435749d12": _COMPILED_KERNELS + "; " + _CODE_ONLY + "; " + _DENSE_RULE + "; "
                            + _NAN_ITERATE + ", the facet contact with finite strain allowed",
        "4f8939b91af98a9d": _COMPILED_KERNELS + "; " + _CODE_ONLY + "; " + _DENSE_RULE + "; "
                            + _NAN_ITERATE + ", the opt-in facet contact added",
        "4919b4f465169f88": _COMPILED_KERNELS + "; " + _CODE_ONLY + "; " + _DENSE_RULE + "; "
                            + _NAN_ITERATE + ", rescue mode and the opt-in facet contact added",
    },
    "f7594263f80ad0d4": {
        "209c6c5f6f7c038c": _CODE_ONLY,
        "00df7dcdec639962": _CODE_ONLY + "; " + _DENSE_RULE,
        "0fb388b18c5a441f": _CODE_ONLY + "; " + _DENSE_RULE + "; " + _NAN_ITERATE,
        "51d4fb8435749d12": _CODE_ONLY + "; " + _DENSE_RULE + "; " + _NAN_ITERATE
                            + ", the facet contact with finite strain allowed",
        "4f8939b91af98a9d": _CODE_ONLY + "; " + _DENSE_RULE + "; " + _NAN_ITERATE
                            + ", the opt-in facet contact added",
        "4919b4f465169f88": _CODE_ONLY + "; " + _DENSE_RULE + "; " + _NAN_ITERATE
                            + ", rescue mode and the opt-in facet contact added",
    },
    "209c6c5f6f7c038c": {
        "00df7dcdec639962": _DENSE_RULE,
        "0fb388b18c5a441f": _DENSE_RULE + "; " + _NAN_ITERATE + " (00df7dcdec639962)",
        "51d4fb8435749d12": _DENSE_RULE + "; " + _NAN_ITERATE + ", the facet contact with "
                            "finite strain allowed (00df7dcdec639962)",
        "4f8939b91af98a9d": _DENSE_RULE + "; " + _NAN_ITERATE + ", the opt-in facet contact "
                            "added (00df7dcdec639962)",
        "4919b4f465169f88": _DENSE_RULE + "; " + _NAN_ITERATE + ", rescue mode and the opt-in "
                            "facet contact added (00df7dcdec639962)",
    },
    "00df7dcdec639962": {
        "0fb388b18c5a441f": _NAN_ITERATE,
        "51d4fb8435749d12": _NAN_ITERATE + "; the facet contact with finite strain allowed "
                            "(0fb388b18c5a441f)",
        "4f8939b91af98a9d": _NAN_ITERATE + "; the opt-in facet contact, small and finite "
                            "strain, added (0fb388b18c5a441f)",
        "4919b4f465169f88": _NAN_ITERATE + "; rescue mode and the opt-in facet contact added "
                            "(0fb388b18c5a441f)",
    },
    "0fb388b18c5a441f": {
        "51d4fb8435749d12": "the facet contact with finite strain allowed (contact='facet', "
                            "kinematics='finite', recorded in the identity): the node contact "
                            "and the small-strain facet contact are unchanged",
        "4f8939b91af98a9d": "the opt-in facet contact (51d4fb8435749d12) and its finite-strain "
                            "use added: the default node contact's arithmetic is unchanged",
        "4919b4f465169f88": "rescue mode (4f8939b91af98a9d) and the opt-in facet contact, small "
                            "and finite strain, added: only a load step that failed after "
                            "MAX_CUTBACKS halvings, or a run with contact='facet', is solved "
                            "differently",
    },
    "51d4fb8435749d12": {
        "4f8939b91af98a9d": "opt-in facet contact added (contact='facet', fem/facet_contact.py): "
                            "the default node contact's arithmetic is unchanged",
        "4919b4f465169f88": "rescue mode (4f8939b91af98a9d) and the opt-in facet contact "
                            "added: only a load step that failed after MAX_CUTBACKS halvings, or "
                            "a run with contact='facet', is solved differently",
    },
    "4f8939b91af98a9d": {
        "4919b4f465169f88": "rescue mode added (run._advance, ContactSolver.line_search): only a "
                            "load step that failed after MAX_CUTBACKS halvings is solved "
                            "differently",
    },
}


# Runs an entry of REPRODUCED_FE_CODE leaves out: {(code, older): {input: values}}, the runs of
# the older code with one of those values of that input (a change that alters only the runs of
# one opt-in setting; ``reproduced_code`` with the run's inputs).
REPRODUCED_UNLESS: dict[tuple[str, str], dict[str, tuple]] = {}


def _reproduces(code: str, previous: str, why: str,
                unless: dict[str, tuple] | None = None) -> None:
    """Enter the FE code ``code`` in ``REPRODUCED_FE_CODE``: it reproduces the runs of the code
    ``previous`` by the change ``why`` says, and through it the runs of every code ``previous``
    reproduces (each with the reasons of the chain); ``unless``: the runs it does not
    reproduce of ``previous`` (``REPRODUCED_UNLESS``: an input and its values; a later code
    that reproduces ``code`` leaves them out too)."""
    REPRODUCED_FE_CODE[code] = {
        previous: why,
        **{older: why + "; " + reason for older, reason in REPRODUCED_FE_CODE[previous].items()},
    }
    if unless:  # the runs of ``previous`` it leaves out (older code knew no such runs)
        REPRODUCED_UNLESS[(code, previous)] = dict(unless)
    for older in REPRODUCED_FE_CODE[previous]:  # and those ``previous`` left out
        if (previous, older) in REPRODUCED_UNLESS:
            REPRODUCED_UNLESS[(code, older)] = dict(REPRODUCED_UNLESS[(previous, older)])


_reproduces("ce4ea917d58ececb", "07275231518417f5", _EDGE_YIELD)

_SETTINGS_OBJECT = ("the FE settings in one object (fem.settings.FeSettings, added to the sources: "
                    "defaults, validation and identity record as before, the recorded inputs "
                    "equal for every setting); run_history split into prepare_run, step_loop "
                    "and run_summary with the same arithmetic in the same order, its messages "
                    "through notify")
_reproduces("163d9399ec173f3c", "ce4ea917d58ececb", _SETTINGS_OBJECT)


_EDGE_SURFACE = ("the first-yield search of a grain whose analytic first yield is at the contact "
                 "edge also evaluates the yield ratio on the surface at the edge "
                 "(ContactSolver.edge_surface_ratio; the identity's first_yield entry renamed): "
                 "the runs of every other grain are computed and summarised as before")
_reproduces("3399407d181157cd", "163d9399ec173f3c", _EDGE_SURFACE)

_COMPILED_SMALL_STRAIN = ("the opt-in compiled small-strain kernels added (kernels='compiled' "
                          "with kinematics='small', refused before; recorded in the identity as "
                          "kernels) and the --kernels flag (passed on only when not at its "
                          "default): fem.run._solver builds the numpy path's solvers as before")
_reproduces("82eb800afc111cfd", "3399407d181157cd", _COMPILED_SMALL_STRAIN)


_ADAPTIVE_STEPS = ("the opt-in adaptive load-step control added (step_control='adaptive', "
                   "fem.run.AdaptiveSteps; recorded in the identity as step_control when not "
                   "'fixed'): the fixed control's solves, summary and checkpoint are as before")
_reproduces("a96dc9b1776d119a", "82eb800afc111cfd", _ADAPTIVE_STEPS)

# The FE code of the compiled default (issue 36) and the compiled code it was shown with.
_DEFAULT_FE_CODE, _DEFAULT_COMPILED_CODE = "a8b8a85c2abfc49d", "cb2fe24353811668"
_KERNELS_DEFAULT = ("the element kernels' default resolved per run (fem.settings.default_kernels: "
                    "compiled with the node contact, numpy with the facet contact; kernels "
                    "recorded where not at that default, fem.identity.recorded_kernels reading "
                    "every older record as made), the process CPU time of the run in "
                    "summary.json and its checkpoint (cpu_time_s, compared nowhere) and one "
                    "rescue-mode solve (run._rescue) for the fixed and adaptive steps, the same "
                    "calls in the same order: a run on the numpy path computes as before")
_reproduces(_DEFAULT_FE_CODE, "a96dc9b1776d119a", _KERNELS_DEFAULT)

# The mesh rule chosen from the material and the load (issue 36, fem.settings.chosen_mesh_rule).
_AUTO_MESH_RULE_CODE = "eda0d948e9431144"
_AUTO_MESH_RULE = ("the opt-in mesh rule 'auto' added (refused before; resolved to a concrete "
                   "rule before the identity is made, which records that rule, never 'auto') "
                   "and the record compared with each setting's default when it entered the "
                   "identity (fem.settings.RECORD_DEFAULTS, equal to today's defaults): every "
                   "run is meshed, solved and recorded as before")
_reproduces(_AUTO_MESH_RULE_CODE, _DEFAULT_FE_CODE, _AUTO_MESH_RULE)

# The verified settings made the defaults (issue 36, docs/fem.md "Defaults").
_DEFAULTS_CODE = "f17f50983599a3e1"
_DEFAULTS_SWITCH = ("the mesh rule 'auto' and the adaptive load-step control made the defaults "
                    "(FeSettings, FemJob, run_cycles, the CLI), each setting still recorded "
                    "against its default when it entered the identity (RECORD_DEFAULTS), so a "
                    "run asked by its settings is meshed, solved and recorded as before; "
                    "summary.json gains 'choice' (the rule, the control and why: a function of "
                    "the inputs, which fem.settings.recorded_choice gives for an older run)")
_reproduces(_DEFAULTS_CODE, _AUTO_MESH_RULE_CODE, _DEFAULTS_SWITCH)

# The dissipation-bounded adaptive control made the default (issue 36, docs/fem.md "The
# dissipation bound").
_DISSIPATION_CODE = "6e8768ce8585cba6"
_DISSIPATION_CONTROL = ("the load-step control 'dissipation' added (fem.run.AdaptiveSteps with "
                        "the plastic dissipation of a solve in place of its largest eqps "
                        "increment; recorded in the identity as step_control, which an earlier "
                        "run records as 'adaptive' or not at all) and made the default: a run "
                        "with fixed steps or the 'adaptive' control is solved, checkpointed and "
                        "summarised as before")
_reproduces(_DISSIPATION_CODE, _DEFAULTS_CODE, _DISSIPATION_CONTROL)

# Branches (issue 37, docs/fem.md "Branches"): a run may follow another's loading ramp to one of
# its steps and go on from there, from that run's snapshot.
_BRANCH_CODE = "4aeedf54d2157bf5"
_BRANCHES = ("the opt-in branch added (run_history follows=(base forces, step), recorded in the "
             "identity as follows only when given; snapshots= saves a run's checkpoint after "
             "every step, start= starts a branch from one, neither in the identity): the load "
             "schedule of a run that follows nothing is load_schedule's as before "
             "(fem.run.run_schedule), and its steps, checkpoints and summary are as before")
_reproduces(_BRANCH_CODE, _DISSIPATION_CODE, _BRANCHES)

# The "envelope" control (issues 36 and 37, docs/fem.md "The envelope control"): a reload below
# the envelope is measured against itself. Its first form (b91341923e5d4e1f) counted only the
# edge's advance onto fresh surface; the second (4a1e7207570fa809) also holds the reload's plastic
# dissipation to a tenth of the reload's own, and reproduces every run of the first but those of
# the envelope control.
_ENVELOPE_FIRST_CODE = "b91341923e5d4e1f"
_ENVELOPE_CODE = "4a1e7207570fa809"
_ENVELOPE = ("the opt-in load-step control 'envelope' added (step_control='envelope', "
             "fem.run.ENVELOPE_CONTROLS; resolved to 'dissipation' for a history that never "
             "reloads, fem.settings.resolved_step_control, so such a run keeps its key): a run "
             "with any other control, and one whose history never reloads, is solved, "
             "checkpointed and summarised as before; and the fully plastic onset read on "
             "virgin loading only (fem.run.fully_plastic_onset): a run whose onset the older "
             "code read off a reload is not reused (_onset_off_virgin_loading; none of the 128 "
             "committed runs), every other run's summary is as before")
_reproduces(_ENVELOPE_FIRST_CODE, _BRANCH_CODE, _ENVELOPE)
_ENVELOPE_RELOAD = ("the envelope control's reload also bounded by its own plastic dissipation "
                    "(fem.run.Envelope): the runs of every other control are solved as before, "
                    "those of 'envelope' are not reproduced")
_reproduces(_ENVELOPE_CODE, _ENVELOPE_FIRST_CODE, _ENVELOPE_RELOAD,
            unless={"step_control": ("envelope",)})
# The third form (727fa14189b8b528): on the dent's rim, within ENVELOPE_RIM_ELEMENTS surface
# elements of the envelope's contact radius, the edge bound counts the edge's whole advance
# (docs/fem.md "The envelope control"; its late cycles converge there,
# docs/verification/envelope-control.json).
_ENVELOPE_RIM_CODE = "727fa14189b8b528"
_ENVELOPE_RIM = ("the envelope control's edge bound counts the whole advance on the dent's rim "
                 "(fem.run.ENVELOPE_RIM_ELEMENTS): the runs of every other control are solved as "
                 "before, those of 'envelope' are not reproduced")
_reproduces(_ENVELOPE_RIM_CODE, _ENVELOPE_CODE, _ENVELOPE_RIM,
            unless={"step_control": ("envelope",)})

# Backtracking (issues 36 and 37, docs/fem.md "Backtracking"): the opt-in Newton updates of the
# hard, perfectly plastic corner. Evidence: the cyclic history [0, 0.3 N] x 3 and the ramp under
# "dissipation" and "envelope" (reference-weak, coarse mesh, finite strain, decade steps), old code
# against new on one machine: byte-identical curve.csv, summaries equal but for identity and
# times.
_BACKTRACKING_CODE = "6b11bcf14a03e335"
_BACKTRACKING = ("the opt-in Newton backtracking added (newton='backtracking', "
                 "ContactSolver.backtracking; recorded in the identity as newton when not "
                 "'full') and rescue mode's trial iterate shared with it (ContactSolver._trial, "
                 "the same arithmetic): a run with full updates is solved, checkpointed and "
                 "summarised as before")
_reproduces(_BACKTRACKING_CODE, _ENVELOPE_RIM_CODE, _BACKTRACKING)

# The solver split into its parts (issue 36, docs/fem.md "The engine's parts"): State in
# fem/state.py, the linear systems in fem/linear_algebra.py, the contact's outputs in
# fem/contact_outputs.py, the facet contact's Newton iteration in fem/facet_contact.py, mixed
# into ContactSolver; the three new modules are FE sources. Code moved, no operation changed.
# Evidence, old code (a worktree of 17d22ba) against new on one machine (reference-weak, coarse
# mesh, decade steps): finite strain, the cyclic history [0, 0.3 N] x 3 under "dissipation", the
# ramp under "dissipation", "envelope" and with newton="backtracking"; small strain on the numpy
# path, the cyclic history; the facet contact, the ramp. Byte-identical curve.csv files,
# summaries equal but for identity and times.
_SPLIT_CODE = "5b231cdf85152494"
_SPLIT = ("ContactSolver split into modules (fem.state, fem.linear_algebra, fem.contact_outputs, "
          "fem.facet_contact's FacetNewton), the code moved as it was: every run is solved, "
          "checkpointed and summarised as before")
_reproduces(_SPLIT_CODE, _BACKTRACKING_CODE, _SPLIT)

# The force bound from the measured contact (issue 37, docs/fem.md "The largest contact a run
# resolves"): a run stops at the first recorded step whose contact radius passes
# mesh.CONTACT_RADIUS_LIMIT R (ContactBeyondMeshError, a ConvergenceError), where the older code
# went on out of the mesh's refined zone; such a run is not reused (_contact_beyond_mesh; none of
# the 216 committed runs, the largest contact 0.467 R). The mesh's clip at R/2 is the same
# constant. Evidence: old code (a worktree of the commit before) against new on one machine, the
# cyclic history [0, 0.3 N] x 3 and the ramp under "dissipation" and "envelope"
# (reference-weak, coarse, finite strain, decade steps): byte-identical curve.csv, summaries
# equal but for identity and times.
_CONTACT_LIMIT_CODE = "069f7583caba9102"
_CONTACT_LIMIT = ("a run stops where its measured contact radius passes the mesh's refined "
                  "zone (fem.mesh.CONTACT_RADIUS_LIMIT R; fem.run.step_loop): every run whose "
                  "contact stayed within it is solved, checkpointed and summarised as before, "
                  "and one that did not is not reused (_contact_beyond_mesh)")
_reproduces(_CONTACT_LIMIT_CODE, _SPLIT_CODE, _CONTACT_LIMIT)

# The internal force of a converged state kept for the last state asked (ContactSolver.
# state_internal_force; issue 36): the same computation, made once per state instead of about
# three times (the step control's contact radius, the record's outputs, the next predictor).
# Evidence: old code (a worktree of the commit before) against new on one machine, the cyclic
# history [0, 0.3 N] x 3 and the ramp under "dissipation" and "envelope" (reference-weak, coarse,
# finite strain, decade steps, compiled kernels), the cyclic history in small strain on the numpy
# path and the ramp with the facet contact in finite strain: byte-identical curve.csv, summaries
# equal but for identity and times.
_FORCE_KEPT_CODE = "fdf575e174e79bc1"
_FORCE_KEPT = ("the internal force of a converged state computed once and kept for the last "
               "state asked (ContactSolver.state_internal_force), the same arithmetic: every "
               "run is solved, checkpointed and summarised as before")
_reproduces(_FORCE_KEPT_CODE, _CONTACT_LIMIT_CODE, _FORCE_KEPT)

# The mesh's smallest resolved contact as an opt-in setting (issue 37, docs/fem.md "Starting the
# resolved mesh later"): FeSettings.resolve_from, recorded in the identity only when given;
# run_cycles takes the FE settings as keywords (the same values reach run_history). Evidence:
# old code (a worktree of the commit before) against new on one machine, the cyclic history
# [0, 0.3 N] x 3 under "dissipation" and "envelope", the ramp under "dissipation" and with
# backtracking (reference-weak, coarse, finite strain, decade steps, compiled kernels), the
# cyclic history in small strain on the numpy path and the ramp with the facet contact:
# byte-identical curve.csv, summaries equal but for identity and times.
_RESOLVE_FROM_CODE = "06dd17f121d8098b"
_RESOLVE_FROM = ("the opt-in smallest resolved contact added (resolve_from, fem.run.history_mesh; "
                 "recorded in the identity only when given): every run without it is meshed, "
                 "solved, checkpointed and summarised as before")
_reproduces(_RESOLVE_FROM_CODE, _FORCE_KEPT_CODE, _RESOLVE_FROM)

# Changes whose runs reproduce the older runs within a stated tolerance, not bit for bit (the
# agreement rule; docs/fem.md "The agreement rule"): e.g. the compiled element kernels
# (fem.compiled) against the numpy path they were written after, whose round-off differs
# (another order of the sums, fused multiply-adds). A job on such code may reuse a finished numpy
# run of an FE code listed here, with every other input equal (``equivalent_run``), as the same
# run within ``tolerance``: relative, in every curve value (to its column's largest magnitude)
# and every number of summary.json (to its own), stated below the Newton tolerance (TOLERANCE,
# 1e-8, the accuracy of any run) and above the measured differences with a wide margin
# (AGREEMENT_TOLERANCE, 1e-10, for round-off). The reused run keeps its record; the result says
# it was reused under this rule (``summary["reused"]``). Keyed by the engine's code, (FE code,
# compiled code: ``compiled_code_hash``), then by the FE code of the numpy runs it agrees with.
# An entry is made only with its evidence: committed runs, a finite-strain one among them,
# rerun on the kernels by ``scripts/reproduce_fe_runs.py --kernels compiled`` under that code,
# every one within the tolerance with the same Newton iterations.
#
# The compiled kernels as merged with fe-solver's factoriser (compiled code 61cf57a372a3c19d,
# reuse_factor on) took no entry: they rerun the committed finite-strain weak run
# (weak-finite-coarse bcc780a) with the same Newton iterations but up to 7.4e-9 apart in plastic
# dissipation, 5.4e-7 in a cycle's loop work and 0.17 of the largest count of plastic points at
# one step (reuse_factor's inexact CG solves, not round-off; fe-kernels-agreement.json). With
# reuse_factor off (its default since) the solves are direct again, and the reruns agree to
# round-off: the entry below, which makes the compiled kernels the node contact's default.
@dataclass(frozen=True)
class Agreement:
    """Why the runs of a code agree with older ones, within what, and the record showing it."""

    why: str
    tolerance: float  # relative, in every curve value and summary number
    evidence: str  # the reruns' record, a path in the repository

    def __post_init__(self) -> None:
        if not (isinstance(self.tolerance, float) and 0.0 < self.tolerance < TOLERANCE):
            raise ValueError(f"Agreement.tolerance: must be a float in (0, {TOLERANCE:g}) "
                             f"(below the Newton tolerance), got {self.tolerance!r}")
        if not (isinstance(self.evidence, str) and self.evidence.endswith(".json")):
            raise ValueError(f"Agreement.evidence: must be the path of the reruns' JSON record, "
                             f"got {self.evidence!r}")


AGREEMENT_TOLERANCE = 1e-10
_KERNELS_AGREE = Agreement(
    why=("the compiled element kernels (fem.compiled: small and finite strain, node contact, "
         "direct solves), the node contact's default, against the numpy path: the same "
         "equations in another order of round-off; reruns of committed runs took the same "
         "steps and Newton iterations and agreed within 3.4e-12"),
    tolerance=AGREEMENT_TOLERANCE, evidence="docs/verification/fe-kernels-agreement.json")
# The FE codes whose engine on the compiled default's kernels agrees with the numpy runs of its
# own FE code and of every code it reproduces bit for bit (the committed runs' among them), each
# with its reruns in the evidence file: the compiled default's code, then the codes after it
# (the "auto" mesh rule, the switched defaults, the dissipation control, the branches, the
# envelope control and its rim, backtracking, the solver's split, the measured contact's bound,
# the internal force kept, the smallest resolved contact).
_KERNELS_AGREE_CODES = (_DEFAULT_FE_CODE, _AUTO_MESH_RULE_CODE, _DEFAULTS_CODE, _DISSIPATION_CODE,
                        _BRANCH_CODE, _ENVELOPE_CODE, _ENVELOPE_RIM_CODE, _BACKTRACKING_CODE,
                        _SPLIT_CODE, _CONTACT_LIMIT_CODE, _FORCE_KEPT_CODE, _RESOLVE_FROM_CODE)
AGREED_FE_CODE: dict[tuple[str, str], dict[str, Agreement]] = {
    (code, _DEFAULT_COMPILED_CODE): {older: _KERNELS_AGREE
                                     for older in (code, *REPRODUCED_FE_CODE[code])}
    for code in _KERNELS_AGREE_CODES}


def agreed_code(recorded: Any, compiled_code: Any) -> Agreement | None:
    """The agreement under which a numpy run recorded with the FE source hash ``recorded``
    stands in for a run of the current FE code on the compiled kernels ``compiled_code``
    (``AGREED_FE_CODE``), or None."""
    return AGREED_FE_CODE.get((fe_code_hash(), compiled_code), {}).get(recorded)


def reproduced_code(recorded: Any, inputs: Any = None) -> str | None:
    """Why a run recorded with the FE source hash ``recorded`` (and the identity ``inputs``,
    where given) is reproduced by the current sources (``REPRODUCED_FE_CODE``), or None: also
    None for a run an entry leaves out (``REPRODUCED_UNLESS``; without ``inputs`` such an
    entry reproduces nothing)."""
    current = fe_code_hash()
    why = REPRODUCED_FE_CODE.get(current, {}).get(recorded)
    left_out = REPRODUCED_UNLESS.get((current, recorded)) if why is not None else None
    if left_out and (not isinstance(inputs, dict) or any(
            inputs.get(name) in values for name, values in left_out.items())):
        return None
    return why


def code_fingerprint(source: str) -> str:
    """The code of a Python source: its syntax tree without docstrings and import statements.
    Moving a module, renaming what it imports from, or editing its comments and docstrings leaves
    it unchanged; any change of what the code computes changes it."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        kept = [n for n in body if not isinstance(n, (ast.Import, ast.ImportFrom))]
        if (kept and isinstance(kept[0], ast.Expr) and isinstance(kept[0].value, ast.Constant)
                and isinstance(kept[0].value.value, str)):
            kept = kept[1:]
        node.body = kept or [ast.Pass()]
    return ast.dump(tree, annotate_fields=False)


def sources_hash(root: Path) -> str:
    """The hash of ``FE_SOURCES``' code under the package folder ``root``."""
    digest = hashlib.sha256()
    for name in FE_SOURCES:
        path = root.joinpath(*name.split(".")).with_suffix(".py")
        digest.update(code_fingerprint(path.read_text()).encode())
    return digest.hexdigest()[:16]


@functools.cache
def fe_code_hash() -> str:
    """Hash of the FE engine's code (``FE_SOURCES``, ``code_fingerprint``)."""
    return sources_hash(Path(__file__).resolve().parent.parent)


@functools.cache
def compiled_code_hash() -> str:
    """Hash of the compiled kernels' code, recorded in the identity of a run with
    ``kernels="compiled"`` (``compiled_code``): fem/compiled.py's code (``code_fingerprint``)
    and the C++ source the loaded ``_kernels`` module was built from (its ``SOURCE_HASH``, the
    sha256 CMake takes at build time: the wheel leaves the source out). Not in ``FE_SOURCES``,
    so an edit of the kernels leaves the numpy path's runs as they are."""
    from . import compiled

    digest = hashlib.sha256(code_fingerprint(Path(compiled.__file__).read_text()).encode())
    digest.update(str(compiled.kernels().SOURCE_HASH).encode())
    return digest.hexdigest()[:16]


@functools.cache
def distribution_version(name: str) -> str:
    """Installed version of the distribution ``name`` ("absent" if it is not installed); read
    once per process, as the modules in use are the ones loaded then."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "absent"


def library_versions() -> dict[str, str]:
    return {name: distribution_version(name) for name in LIBRARIES}


@dataclass(frozen=True)
class FeRunIdentity:
    """Everything that decides an FE run's result: the material, the force history and the
    settings (``fem.settings.FeSettings``) with their defaults resolved (an omitted
    ``steps_per_segment`` is the mesh preset's, an omitted ``mesh_force`` the largest force),
    so two spellings of the same run have the same key. The settings read through it
    (``identity.kinematics``)."""

    material: Material
    forces: tuple[float, ...]
    settings: FeSettings
    # a branch (``follows``): the run follows the loading ramp ``(0, F)`` of another run (the
    # base: these forces, the same material and settings) to its recorded step ``step``, then
    # goes on with ``forces[1:]`` from there (forces[1] is that step's force): (base forces,
    # step), None for a run of its own
    follows: tuple[tuple[float, ...], int] | None = None

    @classmethod
    def of(cls, material: Material, forces, mesh: str = "coarse",
           **settings: Any) -> FeRunIdentity:
        """The identity of ``run_history(material, forces, mesh, **settings)`` (FeSettings
        keywords); one-line InputError on an input the FE would refuse."""
        return cls.of_settings(material, forces, FeSettings(mesh, **settings))

    @classmethod
    def of_settings(cls, material: Material, forces, settings: FeSettings,
                    follows=None) -> FeRunIdentity:
        """``follows``: None, or (base forces, step) of a branch (``fem.run.run_history``):
        the base is a loading ramp (0, F), the step a whole number >= 1, and the branch's
        history starts at 0 and goes to the step's force first. The settings are resolved on
        the base's forces (its mesh is the base's), the load-step control on the branch's own
        (``resolved_step_control``: its reloads are its own)."""
        forces = tuple(validate_forces(list(forces)))
        if follows is None:
            return cls(material, forces, settings.resolved(forces, material))
        base, step = check_follows(follows)
        if len(forces) < 2 or forces[1] <= 0.0:
            raise InputError("follows: a branch's history starts at 0 N and goes first to the "
                             f"force of the base's step {step}; got {list(forces)!r}")
        resolved = settings.resolved(base, material)
        resolved = replace(resolved, step_control=resolved_step_control(settings.step_control,
                                                                        forces))
        return cls(material, forces, resolved, (base, step))

    def base(self) -> FeRunIdentity:
        """The identity of the run a branch follows (``follows``): its settings with the
        load-step control resolved on the base's ramp."""
        if self.follows is None:
            raise ValueError("FeRunIdentity.base: not a branch")
        ramp = self.follows[0]
        return FeRunIdentity(self.material, ramp, replace(
            self.settings, step_control=resolved_step_control(self.settings.step_control, ramp)))

    def __getattr__(self, name: str) -> Any:
        if name in _SETTINGS:
            return getattr(self.settings, name)
        raise AttributeError(name)

    def inputs(self) -> dict[str, Any]:
        """The inputs as ``summary.json`` records them (``inputs``)."""
        record = {"material": self.material.to_dict(), "forces_N": list(self.forces),
                  **self.settings.record()}
        if incipient_yield(self.material).at_surface:
            record["first_yield"] = EDGE_FIRST_YIELD
        if self.follows is not None:  # only a branch records it: other runs' keys unchanged
            record["follows"] = {"forces_N": list(self.follows[0]), "step": self.follows[1]}
        return record

    def to_dict(self) -> dict[str, Any]:
        """Inputs, FE source hash and library versions, and the key of them all."""
        record = {"schema": SCHEMA, "inputs": self.inputs(), "fe_code": fe_code_hash(),
                  "libraries": library_versions()}
        if self.kernels == "compiled":  # only then: the numpy path's records as they were
            record["compiled_code"] = compiled_code_hash()
        return {"key": identity_key(record), **record}

    def key(self) -> str:
        """Hash of everything that decides the result (the cache entry's name)."""
        return self.to_dict()["key"]

    def describe(self) -> str:
        """The inputs in a few words, for messages."""
        m = self.material
        settings = [f"forces {', '.join(f'{f:g}' for f in self.forces)} N",
                    *self.settings.describe(max(self.forces))]
        settings.append(f"E = {m.youngs_modulus:.3g} Pa, nu = {m.poissons_ratio:g}, "
                        f"sigma_c = {m.compressive_yield_stress:.3g} Pa, "
                        f"beta = {m.friction_angle_deg:g} deg, m = {m.hardening_ratio:g}, "
                        f"R = {m.radius:g} m")
        return "; ".join(settings)


def check_follows(follows) -> tuple[tuple[float, ...], int]:
    """(base forces, step) of a branch, checked: the base a loading ramp (0, F > 0) and the
    step a whole number >= 1; one-line InputError otherwise."""
    try:
        base, step = follows
    except (TypeError, ValueError):
        raise InputError(f"follows: expected (base forces, step), got {follows!r}") from None
    base = tuple(validate_forces(list(base)))
    if len(base) != 2:
        raise InputError("follows: the base must be a loading ramp (0, F) with F > 0 N, got "
                         f"forces {list(base)!r}")
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise InputError(f"follows: the step must be a whole number >= 1, got {step!r}")
    return base, int(step)


def identity_key(record: dict[str, Any]) -> str:
    """The key of an identity record (``FeRunIdentity.to_dict`` without or with its ``key``):
    the hash of everything else in it."""
    body = {name: value for name, value in record.items() if name != "key"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()[:20]


# Inputs computed on another machine can come out a few ulp apart: numpy picks SIMD code for
# its log/exp/power at run time, so the calibration's geometric peak loads differed in the last
# bit between two CPUs (591.6198855854117 against ...118 N) and a committed run of hours was not
# reused. A run whose numbers agree with the job's to this relative rounding is the same run.
ROUNDING = 1e-12


def same_to_rounding(recorded: Any, current: Any) -> bool:
    """Whether two JSON-like records are equal, floats to ``ROUNDING`` (relative), everything
    else (keys, lengths, strings, integers, booleans) exactly."""
    if isinstance(recorded, dict) and isinstance(current, dict):
        return recorded.keys() == current.keys() and all(
            same_to_rounding(recorded[k], current[k]) for k in current)
    if isinstance(recorded, list) and isinstance(current, list):
        return len(recorded) == len(current) and all(
            same_to_rounding(a, b) for a, b in zip(recorded, current, strict=True))
    if isinstance(recorded, float) and isinstance(current, float):
        return math.isclose(recorded, current, rel_tol=ROUNDING, abs_tol=0.0)
    return type(recorded) is type(current) and recorded == current


def recorded_kernels(record: dict[str, Any]) -> str:
    """The element kernels an identity record's run was made on: its inputs' ``kernels`` where
    recorded (not at the contact's default), else compiled if it records ``compiled_code``
    (a node-contact run at its default, since the compiled default), else numpy (the facet
    contact's default, and every default run before the compiled default)."""
    inputs = record.get("inputs")
    if isinstance(inputs, dict) and "kernels" in inputs:
        return inputs["kernels"]
    return "compiled" if "compiled_code" in record else "numpy"


def _without_engine(record: dict[str, Any]) -> tuple[dict[str, Any], Any]:
    """An identity record without what names its engine (key, FE code, kernels, compiled
    code), and its inputs without ``kernels``: what two runs of the same job share."""
    rest = {name: value for name, value in record.items()
            if name not in ("key", "fe_code", "compiled_code", "inputs")}
    inputs = record.get("inputs")
    if isinstance(inputs, dict):
        inputs = {name: value for name, value in inputs.items() if name != "kernels"}
    return rest, inputs


def reuse_rule(recorded: dict[str, Any], current: dict[str, Any], *,
               agreement: bool = False) -> str | None:
    """Under which rule the run of the identity record ``recorded`` stands in for the run of
    ``current`` (``to_dict()`` of both), their numeric inputs equal to ``ROUNDING``:
    "reproduced" (the same kernels and compiled code, and the current FE code or one whose
    runs it reproduces bit for bit, ``REPRODUCED_FE_CODE``), with ``agreement`` also "agreed"
    (a numpy run of FE code whose runs the current compiled kernels reproduce within a stated
    tolerance, ``AGREED_FE_CODE``); None if neither."""
    rest, inputs = _without_engine(recorded)
    current_rest, current_inputs = _without_engine(current)
    if rest != current_rest or not same_to_rounding(inputs, current_inputs):
        return None
    kernels = recorded_kernels(recorded)
    if (kernels == recorded_kernels(current)
            and recorded.get("compiled_code") == current.get("compiled_code")
            and (recorded.get("fe_code") == current["fe_code"]
                 or reproduced_code(recorded.get("fe_code"), recorded.get("inputs")) is not None)):
        return "reproduced"
    if (agreement and kernels == "numpy" and recorded_kernels(current) == "compiled"
            and agreed_code(recorded.get("fe_code"), current.get("compiled_code")) is not None
            and (recorded.get("fe_code") == current["fe_code"]
                 or reproduced_code(recorded.get("fe_code"), recorded.get("inputs")) is not None)):
        return "agreed"
    return None


def difference(recorded: Any, identity: FeRunIdentity, *, rounding: bool = False,
               agreement: bool = False) -> str | None:
    """What differs between a recorded identity (``to_dict()`` of an earlier run) and
    ``identity``, in a few words; None when they are the same. With ``rounding``, numeric
    inputs that agree to ``ROUNDING`` count as the same, and so does FE code whose runs the
    current code reproduces (``REPRODUCED_FE_CODE``); with ``agreement`` also a numpy run that
    the current compiled kernels reproduce within a stated tolerance (``AGREED_FE_CODE``). The
    record must still be intact (its key the hash of the rest)."""
    current = identity.to_dict()
    if not isinstance(recorded, dict) or recorded.get("schema") != SCHEMA:
        return "made by an older FE (no identity record)"
    if all(recorded.get(name) == value for name, value in current.items()):
        return None  # the whole record, not only its key: a hand-edited record is not trusted
    if (rounding and recorded.get("key") == identity_key(recorded)
            and reuse_rule(recorded, current, agreement=agreement) is not None):
        return None
    if recorded.get("fe_code") != current["fe_code"]:
        return "made by other FE code"
    if recorded.get("compiled_code") != current.get("compiled_code"):
        return "made by other compiled kernels"
    theirs = recorded.get("libraries") or {}
    for name, version in current["libraries"].items():
        if theirs.get(name) != version:
            return f"made with {name} {theirs.get(name)} (now {version})"
    inputs = recorded.get("inputs") or {}
    for name, value in current["inputs"].items():
        if inputs.get(name) != value:
            return f"made with other inputs ({name})"
    return "made with another identity"


def load_result(directory: str | Path) -> FemResult:
    """A result directory written by ``run_history(out=...)`` back as a FemResult."""
    directory = Path(directory)
    try:
        summary = json.loads((directory / "summary.json").read_text())
        with open(directory / "curve.csv", newline="") as fh:
            rows = list(csv.reader(fh))
        header, body = rows[0], rows[1:]
        data = np.array(body, dtype=float).reshape(len(body), len(header))
    except (OSError, ValueError, IndexError) as exc:
        raise InputError(f"FE result {directory}: unreadable ({exc})") from None
    missing = [c for c in CURVE_COLUMNS if c not in header]
    if missing:
        raise InputError(f"FE result {directory}: curve.csv lacks columns {missing}")
    curve = {name: data[:, i] for i, name in enumerate(header)}
    for name in ("step", "plastic_points", "iterations"):
        if name in curve:
            curve[name] = curve[name].astype(int)
    return FemResult(curve=curve, summary=summary)


def finished_run(directory: str | Path, identity: FeRunIdentity, *, fields: bool = False,
                 why: list[str] | None = None, rounding: bool = False,
                 agreement: bool = False) -> FemResult | None:
    """The finished FE run in ``directory`` if it may stand in for a run of ``identity`` (same
    key: same inputs, FE code and libraries; with ``fields`` also its ParaView files), else
    None. ``why``: a list that receives the reason a run that is there is not reused.
    ``rounding``: numeric inputs equal to ``ROUNDING`` will do (``equivalent_run``);
    ``agreement``: so will a numpy run the compiled kernels agree with (``AGREED_FE_CODE``)."""
    directory = Path(directory)
    if not (directory / "summary.json").exists():
        return None
    try:
        result = load_result(directory)
    except InputError as exc:
        reason = str(exc)
    else:
        reason = difference(result.summary.get("identity"), identity, rounding=rounding,
                            agreement=agreement)
        if reason is None and rounding and directory.name != result.summary["identity"]["key"]:
            reason = "not in the folder of its key"
        if reason is None and _onset_off_virgin_loading(result):
            reason = "its fully plastic onset was read off a reload (older FE code)"
        if reason is None and _contact_beyond_mesh(result):
            reason = ("its contact outgrew the mesh's refined zone (older FE code; the current "
                      "code stops there)")
        if reason is None and fields:
            names = result.summary.get("fields")  # a run with fields has at least one
            if not isinstance(names, list) or not names or not all(
                    (directory / str(name)).is_file() for name in names):
                reason = "written without its ParaView fields"
        if reason is None:
            return result
    if why is not None:
        why.append(reason)
    return None


def _onset_off_virgin_loading(result: FemResult) -> bool:
    """Whether the run's fully plastic onset (summary ``fully_plastic_bracket_N``) was read on a
    step that is not virgin loading: FE code before 4a1e7207570fa809 read it on any step of
    rising force, a reload below the envelope too (fem.run.fully_plastic_onset). Such a run is
    not reused (the reproduction of older runs holds for every other one: none of the 128
    committed runs had it)."""
    bracket = result.summary.get("fully_plastic_bracket_N")
    if not bracket:
        return False
    force = np.asarray(result.curve["force_N"], dtype=float)
    steps = np.flatnonzero(force == bracket[1])
    return steps.size > 0 and all(force[k] <= np.max(force[:k], initial=-np.inf)
                                  for k in steps)


def _contact_beyond_mesh(result: FemResult) -> bool:
    """Whether the run's contact radius passed ``mesh.CONTACT_RADIUS_LIMIT`` R at a recorded
    step: FE code before 069f7583caba9102 went on there, out of the mesh's refined zone; the
    current code stops (fem.run.step_loop). Such a run is not reused (the reproduction of older
    runs holds for every other one: none of the 216 committed runs had it, the largest contact
    0.467 R)."""
    radius = np.asarray(result.curve.get("contact_radius_m", ()), dtype=float)
    try:
        grain = float(result.summary["inputs"]["material"]["radius"])
    except (KeyError, TypeError, ValueError):
        return False
    return radius.size > 0 and float(np.max(radius)) > CONTACT_RADIUS_LIMIT * grain


def recorded_identities(cache: str | Path) -> list[tuple[Path, Any]]:
    """Each run folder of the cache folder ``cache`` with its recorded identity (None where
    unreadable): read once for any number of ``equivalent_run`` look-ups."""
    out = []
    for summary in sorted(Path(cache).glob("*/summary.json")):
        try:
            recorded = json.loads(summary.read_text()).get("identity")
        except (OSError, ValueError, AttributeError):
            recorded = None
        out.append((summary.parent, recorded))
    return out


def equivalent_run(cache: str | Path, identity: FeRunIdentity,
                   recorded: list[tuple[Path, Any]] | None = None
                   ) -> tuple[FemResult, str] | None:
    """A finished run in the cache folder ``cache`` (one ``<key>/`` folder per run) that is
    ``identity``'s run up to the rounding of its numeric inputs (``ROUNDING``) and made by the
    current FE code or one it reproduces (``REPRODUCED_FE_CODE``), with the same libraries and
    every other input, with its key; None if there is none. For when the exact key is not
    there: the same campaign's inputs computed on another CPU, or its runs made before a change
    of the FE code that leaves finished runs as they were. A run of the same identity but made
    by the numpy path is found too when the current compiled kernels agree with that FE code's
    runs within a stated tolerance (``AGREED_FE_CODE``); a run reproduced bit for bit is
    preferred to it. Such a result's summary says so (``reused``, ``agreement_record``), the
    folder on disk is left as it is. ``recorded``: the cache's ``recorded_identities``, when
    already read."""
    records = recorded_identities(cache) if recorded is None else recorded
    current = identity.to_dict()
    for agreement in (False, True):
        for directory, record in records:
            # the identity first (cheap), the whole result only for a candidate
            if record is None or difference(record, identity, rounding=True,
                                            agreement=agreement) is not None:
                continue
            result = finished_run(directory, identity, rounding=True, agreement=agreement)
            if result is None:
                continue
            if reuse_rule(record, current) is None:  # agreed, not reproduced
                result.summary["reused"] = agreement_record(record, current)
            return result, directory.name
    return None


def agreement_record(recorded: dict[str, Any], current: dict[str, Any]) -> dict[str, Any]:
    """What a result reused under the agreement rule says of it (``summary["reused"]``): the
    rule, the run's engine and the job's, the tolerance and the evidence."""
    rule = agreed_code(recorded.get("fe_code"), current.get("compiled_code"))
    assert rule is not None  # reuse_rule(..., agreement=True) == "agreed"
    return {"rule": "agreement (fem.identity.AGREED_FE_CODE)", "key": recorded["key"],
            "made_by": {"fe_code": recorded.get("fe_code"), "kernels": "numpy"},
            "for": {"key": current["key"], "fe_code": current["fe_code"],
                    "kernels": "compiled", "compiled_code": current.get("compiled_code")},
            "tolerance": rule.tolerance, "evidence": rule.evidence, "why": rule.why}


def run_key(result: FemResult, identity: FeRunIdentity) -> str:
    """The key of the cache folder ``result`` is in: its recorded identity's (an equivalent run
    reused from another key keeps its own), else ``identity``'s."""
    recorded = result.summary.get("identity")
    return recorded["key"] if isinstance(recorded, dict) and "key" in recorded else identity.key()


def cached_run(cache: str | Path, identity: FeRunIdentity) -> FemResult | None:
    """The run of ``identity`` in the cache folder ``cache``: the one in the folder of its key,
    else an equivalent one (``equivalent_run``); None if neither is there. Its own key (the
    folder it is in) is ``result.summary["identity"]["key"]``."""
    found = finished_run(Path(cache) / identity.key(), identity)
    if found is None:
        equivalent = equivalent_run(cache, identity)
        found = equivalent[0] if equivalent is not None else None
        if found is not None and "reused" in found.summary:
            print(f"fem: {reused_message(found.summary['reused'])}", file=sys.stderr)
    return found


def reused_message(reused: dict[str, Any]) -> str:
    """One line on a run reused under the agreement rule (``agreement_record``)."""
    return (f"reusing {reused['key']}, made by the numpy path of FE code "
            f"{reused['made_by']['fe_code']}: the compiled kernels reproduce its runs within "
            f"{reused['tolerance']:g} relative (fem.identity.AGREED_FE_CODE, "
            f"{reused['evidence']})")


__all__ = ["AGREED_FE_CODE", "FE_SOURCES", "LIBRARIES", "REPRODUCED_FE_CODE", "ROUNDING",
           "Agreement", "FeRunIdentity", "agreed_code", "agreement_record", "cached_run",
           "compiled_code_hash", "difference", "distribution_version", "equivalent_run",
           "fe_code_hash", "finished_run", "identity_key", "library_versions", "load_result",
           "recorded_identities", "recorded_kernels", "reproduced_code", "reuse_rule",
           "reused_message", "run_key", "same_to_rounding"]
