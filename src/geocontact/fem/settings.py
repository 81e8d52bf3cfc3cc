"""The settings of an FE run, in one frozen object: their defaults, their validation, what of them
goes into the run's identity and the command-line flags that set them (docs/fem.md).

    settings = FeSettings(mesh="default", kinematics="finite", max_step_ratio=1.01)
    result = run_history(material, forces, settings=settings)

``run_history``, ``FeRunIdentity`` and ``FemJob`` read their settings from here; the CLI adds
the FE model flags with ``FeSettings.add_model_flags`` and reads them with
``FeSettings.model_of``. A setting the FE would refuse is a one-line InputError naming it and
what is allowed, raised when the object is made, before any work.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from ..errors import InputError
from .mesh import MESH_RULES, mesh_preset
from .result import (
    KINEMATICS,
    STEP_RULES,
    STEPS_PER_SEGMENT,
    TOLERANCE,
    VOLUMETRIC,
    VOLUMETRIC_DEFAULT,
)

# The settings the FE model flags set (``add_model_flags``; FemJob / run_history keywords).
MODEL_FLAGS = ("kinematics", "mesh_rule", "step_rule", "max_step_ratio")
# How each requested load step is solved (fem.run.step_loop): "fixed" (the requested steps,
# each cut into geometric sub-steps of at most max_step_ratio above the first-yield force when a
# cap is given), "adaptive" (sub-steps sized solve by solve from the contact edge's advance,
# the largest plastic strain increment and Newton's effort: fem.run.AdaptiveSteps, docs/fem.md)
# or "dissipation" (the same with the plastic dissipation increment in place of the largest
# plastic strain increment: fem.run.DISSIPATION_INCREMENT; the default) or "envelope" (the
# dissipation control whose edge bound counts, below the largest force reached, only the edge's
# advance beyond the largest contact radius reached: fem.run.ENVELOPE_CONTROLS; for cyclic
# histories, whose reloads re-enter the flattened dent).
STEP_CONTROLS = ("fixed", "adaptive", "dissipation", "envelope")
# The controls that solve a history which never loads again after unloading as another does
# (the same solves: below the envelope is only reached by reloading): resolved to it before the
# identity is made, so such a run is one run, with one key, whichever of the two was asked.
SAME_WITHOUT_RELOADS = {"envelope": "dissipation"}


def reloads(forces) -> bool:
    """Whether the force history ``forces`` loads again after unloading."""
    down = False
    for a, b in itertools.pairwise(forces):
        if b < a:
            down = True
        elif b > a and down:
            return True
    return False


def resolved_step_control(step_control: str, forces) -> str:
    """The load-step control a run of ``forces`` records: ``SAME_WITHOUT_RELOADS``' stand-in
    when the history never reloads (``reloads``), else ``step_control``."""
    if step_control in SAME_WITHOUT_RELOADS and not reloads(forces):
        return SAME_WITHOUT_RELOADS[step_control]
    return step_control
DEFAULT_STEP_CONTROL = "dissipation"
# How a plastic solve's Newton updates are taken (fem.solver, docs/fem.md "Backtracking"): "full"
# (the default: every update whole) or "backtracking" (an update that does not lower the largest
# residual is halved, at most fem.solver.BACKTRACK_HALVINGS times; for perfectly plastic, nearly
# incompressible grains, whose full updates can cycle without converging).
NEWTON_UPDATES = ("full", "backtracking")
# The settings added after the first identity record: recorded only when not at their default,
# so the keys (cache entries, checkpoints) of earlier runs stay valid.
RECORDED_WHEN_SET = ("mesh_rule", "kinematics", "step_rule", "max_step_ratio", "contact",
                     "kernels", "step_control", "newton", "resolve_from")
# The value each of them had by default when it entered the identity: a record leaves a setting
# out only at this value and reads an absent one as it, so a default that moves later keeps every
# older record meaning what it meant. mesh_rule entered as "yield" and step_control as "fixed";
# both defaults moved (issue 36: "auto" and "adaptive", the verified settings, docs/fem.md
# "Defaults"), and a run made on the "yield" meshes or with fixed steps keeps its key, found by a
# job that asks for them (every committed run: their makers name them), while a default run
# records what "auto" chose where that is not "yield" and "adaptive". The kernels' absence is
# read per FE code instead (fem.identity.recorded_kernels).
RECORD_DEFAULTS = {"mesh_rule": "yield", "kinematics": "small", "step_rule": "segment",
                   "max_step_ratio": None, "contact": "node", "step_control": "fixed",
                   "newton": "full", "resolve_from": None}
# The smallest contact radius a mesh resolves, as a fraction of R (``FeSettings.resolve_from``):
# None (the default) resolves every contact from the first load step's (fem.run.
# tip_contact_radius); a value lifts that to resolve_from x R, below which the first steps have
# one or two surface elements under the contact. For runs whose first decades of contact size
# are known (docs/fem.md "Starting the resolved mesh later"): a hard grain's a_y is ~3e-5 R.
RESOLVE_FROM_RANGE = (1e-5, 0.05)
# The mesh rule chosen from the material and the load (issue 36; docs/fem.md "The mesh rule
# chosen from the material and the load"): "auto" resolves, with the history's largest force (the
# mesh force), to "contact-dense" when that force is above AUTO_DENSE_FORCE_RATIO x the analytic
# first-yield force, else to "yield". The ratio is where the "contact" rules' surface band starts
# (fem.run.CONTACT_BAND_FORCE_RATIO) and the staircase criterion's range begins: below it the
# contact stays in the elastic-plastic transition, where the verified "yield" meshes hold; above
# it the node-by-node growth of a flattened contact shows in the force on the "yield" meshes
# (24 vs 48 steps 1.1-6 % apart at 100-10^5 Fy) and not on "contact-dense" (0.16-0.24 %). The
# identity records the rule it resolved to, never "auto".
AUTO_MESH_RULE = "auto"
MESH_RULE_CHOICES = (AUTO_MESH_RULE, *MESH_RULES)
AUTO_DENSE_FORCE_RATIO = 10.0


def chosen_mesh_rule(material, force: float) -> tuple[str, float]:
    """The mesh rule "auto" resolves to for a mesh sized for ``force`` (N) on ``material``, and
    the ratio it was chosen by: ``force`` over the analytic first-yield force
    (geocontact.grain.hertz.incipient_yield), against AUTO_DENSE_FORCE_RATIO."""
    from ..grain.hertz import incipient_yield

    ratio = float(force) / float(incipient_yield(material).force)
    return ("contact-dense" if ratio > AUTO_DENSE_FORCE_RATIO else "yield"), ratio


def settings_choice(material, settings: FeSettings) -> dict[str, Any]:
    """What the resolved ``settings`` of a run on ``material`` chose and why (summary.json
    ``choice``): the mesh rule and the load-step control the run has, the mesh force over the
    analytic first-yield force, the rule "auto" gives at that ratio (``chosen_mesh_rule``)
    against AUTO_DENSE_FORCE_RATIO, and a sentence saying so. A function of the identity's
    inputs alone, so the same for a run asked with "auto" and one asked with the rule it gave
    (the two are one run, with one key)."""
    auto, ratio = chosen_mesh_rule(material, settings.mesh_force)
    return {"mesh_rule": settings.mesh_rule, "step_control": settings.step_control,
            "mesh_force_over_first_yield": ratio, "auto_dense_above": AUTO_DENSE_FORCE_RATIO,
            "auto_mesh_rule": auto, "reason": auto_rule_reason(auto, ratio)}


def recorded_choice(summary: dict[str, Any]) -> dict[str, Any]:
    """summary.json ``choice`` of a finished run, or for a run made before it was recorded (FE
    code before issue 36's switch of the defaults) the same record from its identity's inputs
    (``settings_choice``: it depends on nothing else)."""
    if "choice" in summary:
        return summary["choice"]
    from ..grain.material import Material

    inputs = summary["inputs"]
    return settings_choice(Material(**inputs["material"]), FeSettings.of_record(inputs))


def auto_rule_reason(rule: str, ratio: float) -> str:
    """The sentence saying why "auto" gives ``rule`` at ``ratio`` (mesh force over the analytic
    first-yield force)."""
    side = "above" if ratio > AUTO_DENSE_FORCE_RATIO else "not above"
    return (f"mesh rule auto: {rule} (mesh force {ratio:.4g} x the analytic first-yield force, "
            f"{side} {AUTO_DENSE_FORCE_RATIO:g})")


def default_kernels(contact: str) -> str:
    """The element kernels of a run with the contact ``contact`` when none are asked for: the
    compiled ones (fem.compiled) for the node contact, whose runs agree with the numpy path's to
    ~1e-13 (fem.identity.AGREED_FE_CODE); numpy for the facet contact, which has no compiled
    path."""
    return "compiled" if contact == "node" else "numpy"


@dataclass(frozen=True)
class FeSettings:
    """How an FE run is made (everything but the material and the force history).

    ``mesh``: "coarse" | "default" | "fine" (fem.mesh.PRESETS). ``steps_per_segment``: load
    steps per monotonic segment (None: the preset's, STEPS_PER_SEGMENT). ``tolerance``: Newton
    tolerance relative to the force scale. ``volumetric``: "bbar-p1" | "bbar-p0" | "full".
    ``mesh_force``: size the mesh for this force, >= the history's largest (None: the largest).
    ``mesh_rule``: "auto" (the default: chosen from the material and the load when resolved,
    ``chosen_mesh_rule``) | "yield" | "contact" | "contact-dense" (fem.mesh.MESH_RULES).
    ``kinematics``: "small" | "finite". ``step_rule``: "segment" | "decade"
    (fem.run.load_schedule). ``max_step_ratio``: None or a cap in (1, 2] on the loading force
    ratio of one solve above the first-yield force (fem.run.sub_steps; with the adaptive control
    its largest step, default fem.run.ADAPTIVE_MAX_RATIO). ``step_control``: "dissipation" (the
    default) | "envelope" | "adaptive" (fem.run.AdaptiveSteps) | "fixed" (``STEP_CONTROLS``).
    ``contact``: "node" | "facet". ``kernels``: "numpy" | "compiled" (small or finite strain,
    node contact; fem.compiled) | None, the contact's default (``default_kernels``: compiled
    with the node contact, numpy with the facet contact), which the object holds in its place
    once made. ``newton``: "full" (the default) | "backtracking" (``NEWTON_UPDATES``).
    ``resolve_from``: None (the default) or the smallest contact radius the mesh resolves, a
    fraction of R in ``RESOLVE_FROM_RANGE`` (the first steps' contacts below it are not
    resolved: their forces, and first yield, are the coarse tip's).
    """

    mesh: str = "coarse"
    steps_per_segment: int | None = None
    tolerance: float = TOLERANCE
    volumetric: str = VOLUMETRIC_DEFAULT
    mesh_force: float | None = None
    mesh_rule: str = AUTO_MESH_RULE
    kinematics: str = "small"
    step_rule: str = "segment"
    max_step_ratio: float | None = None
    contact: str = "node"
    kernels: str | None = None
    step_control: str = DEFAULT_STEP_CONTROL
    newton: str = "full"
    resolve_from: float | None = None

    def __post_init__(self) -> None:
        from .compiled import KERNELS  # the FE stack, not needed by the CLI's flags
        from .solver import CONTACTS

        if self.kernels is None and self.contact in CONTACTS:
            object.__setattr__(self, "kernels", default_kernels(self.contact))
        mesh_preset(self.mesh)
        steps = self.steps_per_segment
        if steps is not None and (isinstance(steps, bool) or not _is_integer(steps)
                                  or steps < 1):
            raise InputError(f"steps_per_segment: must be an integer >= 1, got {steps!r}")
        if not _is_number(self.tolerance) or not self.tolerance > 0:
            raise InputError(f"tolerance: must be a positive number, got {self.tolerance!r}")
        for name, allowed in (("volumetric", VOLUMETRIC), ("mesh_rule", MESH_RULE_CHOICES),
                              ("kinematics", KINEMATICS), ("step_rule", STEP_RULES),
                              ("contact", CONTACTS), ("kernels", KERNELS),
                              ("step_control", STEP_CONTROLS), ("newton", NEWTON_UPDATES)):
            value = getattr(self, name)
            if value not in allowed:
                raise InputError(f"{name}: unknown {value!r} (allowed: {', '.join(allowed)})")
        if self.kernels == "compiled" and self.contact != "node":
            raise InputError("kernels: 'compiled' is the engine with the node contact (got "
                             f"contact {self.contact!r})")
        ratio = self.max_step_ratio
        if ratio is not None and not (_is_number(ratio) and 1.0 < ratio <= 2.0):
            raise InputError(f"max_step_ratio: must be a number in (1, 2] or None, "
                             f"got {ratio!r}")
        if self.mesh_force is not None and not (_is_number(self.mesh_force)
                                                and self.mesh_force > 0):
            raise InputError(f"mesh_force: must be a positive number, got {self.mesh_force!r}")
        low, high = RESOLVE_FROM_RANGE
        if self.resolve_from is not None and not (_is_number(self.resolve_from)
                                                  and low <= self.resolve_from <= high):
            raise InputError(f"resolve_from: must be a contact radius over R in [{low:g}, "
                             f"{high:g}] or None, got {self.resolve_from!r}")

    def resolved(self, forces, material=None) -> FeSettings:
        """The settings of a run of the force history ``forces`` with the defaults resolved
        (steps_per_segment the preset's, mesh_force the largest force, the mesh rule "auto" the
        one ``chosen_mesh_rule`` gives for ``material`` at mesh_force), numbers as floats and
        ints, so two spellings of the same run are equal; the control "envelope" the one it
        solves alike when ``forces`` never reload (``resolved_step_control``)."""
        fmax = max(forces)
        mesh_force = fmax if self.mesh_force is None else self.mesh_force
        if mesh_force < fmax:
            raise InputError(f"mesh_force: must be >= the largest force {fmax:g} N, "
                             f"got {self.mesh_force!r}")
        steps = (STEPS_PER_SEGMENT[self.mesh] if self.steps_per_segment is None
                 else self.steps_per_segment)
        rule = self.mesh_rule
        if rule == AUTO_MESH_RULE:
            if material is None:
                raise InputError("mesh_rule: 'auto' is chosen from the material, which was not "
                                 "given (give a concrete rule: " + ", ".join(MESH_RULES) + ")")
            rule = chosen_mesh_rule(material, mesh_force)[0]
        return replace(self, steps_per_segment=int(steps), tolerance=float(self.tolerance),
                       mesh_rule=rule, step_control=resolved_step_control(self.step_control,
                                                                          forces),
                       mesh_force=float(mesh_force),
                       max_step_ratio=(None if self.max_step_ratio is None
                                       else float(self.max_step_ratio)))

    def record(self) -> dict[str, Any]:
        """What of the (resolved) settings the run's identity records (``summary.json``
        ``inputs``, after the material and the forces)."""
        record = {"mesh": self.mesh, "steps_per_segment": self.steps_per_segment,
                  "tolerance": self.tolerance, "mesh_force_N": self.mesh_force,
                  "volumetric": self.volumetric}
        if self.mesh_rule == AUTO_MESH_RULE:
            raise ValueError("FeSettings.record: the mesh rule 'auto' is recorded as the rule it "
                             "resolves to (resolved(forces, material))")
        defaults = {**RECORD_DEFAULTS, "kernels": default_kernels(self.contact)}
        record.update({name: getattr(self, name) for name in RECORDED_WHEN_SET
                       if getattr(self, name) != defaults[name]})
        return record

    @classmethod
    def of_record(cls, inputs: dict[str, Any]) -> FeSettings:
        """The settings of a recorded identity's ``inputs`` (``record`` and the material and
        forces beside it)."""
        return cls(mesh=inputs["mesh"], steps_per_segment=inputs.get("steps_per_segment"),
                   tolerance=inputs["tolerance"], volumetric=inputs["volumetric"],
                   mesh_force=inputs.get("mesh_force_N"),
                   **{name: inputs.get(name, RECORD_DEFAULTS.get(name))
                      for name in RECORDED_WHEN_SET})

    def describe(self, largest_force: float) -> list[str]:
        """The (resolved) settings in a few words each, those at their default left out."""
        words = [f"{self.mesh} mesh", f"{self.steps_per_segment} steps/segment"]
        if self.mesh_force != largest_force:
            words.append(f"mesh sized for {self.mesh_force:g} N")
        if self.tolerance != TOLERANCE:
            words.append(f"tolerance {self.tolerance:g}")
        if self.volumetric != VOLUMETRIC_DEFAULT:
            words.append(f"volumetric {self.volumetric}")
        # the resolved rule is never "auto": named where it is not "yield", the rule a record
        # without mesh_rule was meshed with (RECORD_DEFAULTS), so older runs read as before
        if self.mesh_rule != RECORD_DEFAULTS["mesh_rule"]:
            words.append(f"mesh rule {self.mesh_rule}")
        if self.kinematics != "small":
            words.append(f"{self.kinematics} strain")
        if self.step_rule != "segment":
            words.append(f"step rule {self.step_rule}")
        if self.max_step_ratio is not None:
            words.append(f"loading sub-steps <= x{self.max_step_ratio:g} in force")
        if self.contact != "node":
            words.append(f"{self.contact} contact")
        if self.kernels != default_kernels(self.contact):
            words.append(f"{self.kernels} kernels")
        if self.step_control != FeSettings.__dataclass_fields__["step_control"].default:
            words.append(f"{self.step_control} step control")
        if self.newton != RECORD_DEFAULTS["newton"]:
            words.append(f"{self.newton} Newton updates")
        if self.resolve_from is not None:
            words.append(f"contacts resolved from a = {self.resolve_from:g} R")
        return words

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    @staticmethod
    def names() -> tuple[str, ...]:
        return tuple(f.name for f in fields(FeSettings))

    # --- the command line ----------------------------------------------------------------
    @staticmethod
    def add_model_flags(p) -> None:
        """--kinematics, --mesh-rule, --step-rule, --max-step-ratio, --step-control, --contact,
        --kernels, --newton and --resolve-from of the FE engine (docs/fem.md); their defaults
        are the settings'."""
        default = FeSettings.__dataclass_fields__
        p.add_argument("--kinematics", default=default["kinematics"].default,
                       choices=list(KINEMATICS),
                       help="FE kinematics: small strain (default) or finite strain "
                            "(logarithmic elastic strain, exponential map, F-bar)")
        p.add_argument("--mesh-rule", default=default["mesh_rule"].default,
                       choices=list(MESH_RULE_CHOICES),
                       help="FE mesh rule: 'auto' (default: 'contact-dense' when the largest "
                            f"force is above {AUTO_DENSE_FORCE_RATIO:g} x the analytic "
                            "first-yield force, else 'yield'; the run records the rule chosen "
                            "and why, summary.json 'choice'), 'yield' (the verified meshes of "
                            "the elastic-plastic transition; the rule before issue 36), "
                            "'contact' (small surface elements over the plastic range of "
                            "contact radii: the contact edge of a weak grain moves in steps of "
                            "~1 %% of the radius) or 'contact-dense' (twice as many surface "
                            "elements there)")
        p.add_argument("--step-rule", default=default["step_rule"].default,
                       choices=list(STEP_RULES),
                       help="FE load steps: 'segment' (default, --steps per monotonic segment) "
                            "or 'decade' (also at least --steps/2 geometric loading steps per "
                            "decade of force: for histories spanning many decades of F/Fy)")
        p.add_argument("--max-step-ratio", type=float,
                       default=default["max_step_ratio"].default, metavar="R",
                       help="FE load-step control: solve each loading step above the "
                            "first-yield force through geometric sub-steps of at most R in "
                            "force (e.g. 1.01; the requested steps are still the recorded "
                            "ones): a weak grain's perfectly plastic flattening is step "
                            "dependent (docs/fem.md)")
        p.add_argument("--step-control", default=default["step_control"].default,
                       choices=list(STEP_CONTROLS),
                       help="FE load-step control: 'dissipation' (default: each solve's "
                            "load increment sized by the contact edge's advance against the "
                            "surface element there, the plastic dissipation it adds and "
                            "Newton's effort; --max-step-ratio is then its largest step), "
                            "'adaptive' (the same with the largest plastic strain increment in "
                            "place of the dissipation: the default before) or 'fixed' (the "
                            "requested steps, cut by --max-step-ratio when given; the control "
                            "before issue 36); the recorded steps are the requested ones in "
                            "every control (docs/fem.md)")
        p.add_argument("--contact", default=default["contact"].default,
                       choices=["node", "facet"],
                       help="FE contact with the flat: 'node' (default, exact node-to-flat "
                            "constraint) or 'facet' (penalty integrated over the surface "
                            "facets, the contact edge moving inside an element: no kink in the "
                            "loading curve as a node engages)")
        p.add_argument("--kernels", default=default["kernels"].default,
                       choices=["numpy", "compiled"],
                       help="FE element kernels: 'compiled' (C++, small and finite strain; "
                            "the default with the node contact) or 'numpy' (the default with "
                            "--contact facet): the same results within 1e-10, not bit for "
                            "bit (docs/fem.md)")
        p.add_argument("--newton", default=default["newton"].default,
                       choices=list(NEWTON_UPDATES),
                       help="FE Newton updates of a plastic solve: 'full' (default) or "
                            "'backtracking' (from the third iteration, an update that does "
                            "not lower the largest residual is halved, up to twice: for "
                            "perfectly plastic, nearly incompressible grains whose full "
                            "updates cycle; a solve whose full updates all lower the residual "
                            "is unchanged; docs/fem.md)")
        low, high = RESOLVE_FROM_RANGE
        p.add_argument("--resolve-from", type=float, default=default["resolve_from"].default,
                       metavar="A_OVER_R",
                       help="FE mesh: resolve contacts from this contact radius on, as a "
                            f"fraction of R in [{low:g}, {high:g}] (default: from the first "
                            "load step's; the steps below it have one or two surface elements "
                            "under the contact, so their forces and first yield are not "
                            "resolved; for deep runs of hard grains whose first decades of "
                            "contact size are known; docs/fem.md)")

    @staticmethod
    def model_of(args) -> dict[str, Any]:
        """The FE model the flags of ``add_model_flags`` chose, as settings keywords
        (``contact``, ``kernels``, ``step_control``, ``newton`` and ``resolve_from`` only when
        not the default, so the records of default runs are unchanged)."""
        model = {key: getattr(args, key) for key in MODEL_FLAGS}
        for name in ("contact", "kernels", "step_control", "newton", "resolve_from"):
            if getattr(args, name) != FeSettings.__dataclass_fields__[name].default:
                model[name] = getattr(args, name)
        return model


def _is_number(value: Any) -> bool:
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and math.isfinite(value))


def _is_integer(value: Any) -> bool:
    import numpy as np

    return isinstance(value, (int, np.integer))
