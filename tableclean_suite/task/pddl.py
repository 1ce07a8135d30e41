"""Task specs as PDDL (docs/pddl.md): a domain and problems for any spec, in two forms (``FORMS``),
and a problem of the ``tableclean`` domain read back as a spec.

``"adl"`` reads like the rules (``forall`` preconditions); ``"strips"`` is what every classical
planner takes (objects as constants, ``(off ?o ?s)`` and ``(hand-empty)`` for ADL's negations).
Segments ``s1..sN`` form the ring MOVE follows; the goal is every segment ``wiped``; actions the
model allows without effect are not applicable.  A user action carries its own schema
([`ActionRule.pddl`][tableclean_suite.task.actions.ActionRule]).
"""

from __future__ import annotations

import re
from pathlib import Path

from tableclean_suite.registry import NAME_PATTERN
from tableclean_suite.task.actions import DIGIT_RULES, get_action_rule
from tableclean_suite.task.spec import (DEFAULT_OBJECT_TYPE, PAPER_ACTIONS, SPEC_FILE_READERS, StartMode, TaskSpec,
                                         get_task_spec)
from tableclean_suite.task.state import HELD, TaskState, unclean_layouts

#: The two forms of the export.
FORMS = ("strips", "adl")
#: The ADL domain of the built-in actions, the one problems are read back from.
DOMAIN = "tableclean"
#: The type of a problem's segments; objects have their spec's type names (subtypes of ``item``).
SEGMENT, ITEM = "segment", "item"
PREDICATES = {"strips": "(arm-at ?s - segment) (next ?s ?t - segment) (on ?o - item ?s - segment) "
                        "(off ?o - item ?s - segment) (holding ?o - item) (hand-empty) (wiped ?s - segment)",
              "adl": "(arm-at ?s - segment) (next ?s ?t - segment) (on ?o - item ?s - segment) "
                     "(holding ?o - item) (wiped ?s - segment)"}
_MOVE = """(:action move :parameters (?from ?to - segment)
    :precondition (and (arm-at ?from) (next ?from ?to))
    :effect (and (not (arm-at ?from)) (arm-at ?to)))"""
#: The built-in actions' schemas; ``{off}`` becomes ``(off o1 ?s) ... (off oM ?s)``.
BUILTIN_PDDL = {
    "strips": {"move": _MOVE, "pick": """(:action pick :parameters (?o - item ?s - segment)
    :precondition (and (arm-at ?s) (on ?o ?s) (hand-empty))
    :effect (and (holding ?o) (not (hand-empty)) (not (on ?o ?s)) (off ?o ?s)))""",
               "place": """(:action place :parameters (?o - item ?s - segment)
    :precondition (and (arm-at ?s) (holding ?o))
    :effect (and (on ?o ?s) (not (off ?o ?s)) (not (holding ?o)) (hand-empty)))""",
               "clean": """(:action clean :parameters (?s - segment)
    :precondition (and (arm-at ?s) (hand-empty) {off})
    :effect (wiped ?s))"""},
    "adl": {"move": _MOVE, "pick": """(:action pick :parameters (?o - item ?s - segment)
    :precondition (and (arm-at ?s) (on ?o ?s) (forall (?p - item) (not (holding ?p))))
    :effect (and (holding ?o) (not (on ?o ?s))))""",
            "place": """(:action place :parameters (?o - item ?s - segment)
    :precondition (and (arm-at ?s) (holding ?o))
    :effect (and (on ?o ?s) (not (holding ?o))))""",
            "clean": """(:action clean :parameters (?s - segment)
    :precondition (and (arm-at ?s) (forall (?o - item) (and (not (holding ?o)) (not (on ?o ?s)))))
    :effect (wiped ?s))"""},
}
REQUIREMENTS = {"strips": ":strips :typing", "adl": ":typing :negative-preconditions :universal-preconditions"}


def _form(form: str) -> str:
    if form not in FORMS:
        raise ValueError(f"unknown PDDL form {form!r}; allowed: {', '.join(FORMS)}")
    return form


def domain_name(spec, form: str = "strips") -> str:
    """``tableclean`` (ADL, the paper's actions), else ``tableclean-<spec>[-strips]``."""
    spec = get_task_spec(spec)
    if _form(form) == "adl" and spec.actions == PAPER_ACTIONS:
        return DOMAIN
    return f"{DOMAIN}-{spec.name.replace('_', '-')}" + ("-strips" if form == "strips" else "")


def action_schema(action, form: str, objects: int) -> str:
    """One action's schema in ``form`` for ``objects`` objects; ``ValueError`` names an action without PDDL."""
    rule = get_action_rule(action)
    given = rule.pddl if isinstance(rule.pddl, str) or rule.pddl is None else rule.pddl.get(_form(form))
    if given is None and rule.effect in DIGIT_RULES:
        off = " ".join(f"(off o{j} ?s)" for j in range(1, objects + 1))
        given = BUILTIN_PDDL[form][rule.name].replace("{off}", off)
    if given is None:
        raise ValueError(f"action {rule.name!r} has no PDDL ({form} form); register it with "
                         f"ActionRule(..., pddl=\"(:action {rule.name} ...)\")")
    found = re.match(r"\s*\(\s*:action\s+([^\s()]+)", given)
    if not found or found.group(1).lower() != rule.name:
        raise ValueError(f"action {rule.name!r}: its PDDL must be one '(:action {rule.name} ...)' schema")
    return given.strip()


def domain_pddl(spec, form: str = "strips") -> str:
    """The domain of ``spec``'s actions in ``form``; ``ValueError`` names an action without PDDL."""
    spec = get_task_spec(spec)
    types = " ".join(dict.fromkeys(spec.objects))
    constants = "" if form == "adl" else \
        f"\n  (:constants {' '.join(f'o{j + 1}' for j in range(spec.n_objects))} - {ITEM})"
    actions = "\n  ".join(action_schema(a, form, spec.n_objects) for a in spec.actions)
    return (f"(define (domain {domain_name(spec, form)})\n  (:requirements {REQUIREMENTS[_form(form)]})\n"
            f"  (:types {SEGMENT} {ITEM} - object {types} - {ITEM}){constants}\n"
            f"  (:predicates {PREDICATES[form]})\n  {actions})\n")


def init_facts(state: TaskState, form: str = "strips") -> list[tuple[str, ...]]:
    """The true facts of ``state`` in ``form``, e.g. ``("on", "o1", "s2")`` (segments ``s1..sN``, objects
    ``o1..oM``)."""
    n = len(state.clean)
    facts = [("next", f"s{k + 1}", f"s{(k + 1) % n + 1}") for k in range(n)] + [("arm-at", f"s{state.arm + 1}")]
    for j, where in enumerate(state.objects):
        facts.append(("holding", f"o{j + 1}") if where == HELD else ("on", f"o{j + 1}", f"s{where + 1}"))
        if _form(form) == "strips":
            facts += [("off", f"o{j + 1}", f"s{k + 1}") for k in range(n) if k != where]
    if form == "strips" and not state.holding:
        facts.append(("hand-empty",))
    return facts + [("wiped", f"s{k + 1}") for k in range(n) if state.clean[k]]


def problem_pddl(spec, state: TaskState | None = None, form: str = "strips", name: str | None = None) -> str:
    """The problem of reaching every segment wiped from ``state`` (default the spec's fixed start)."""
    spec = get_task_spec(spec)
    state = spec.initial_state if state is None else state
    segments = [f"s{k + 1}" for k in range(spec.segments)]
    objects = " ".join(segments) + f" - {SEGMENT}"
    if _form(form) == "adl":
        objects += "".join(f" o{j + 1} - {kind}" for j, kind in enumerate(spec.objects))
    facts = " ".join(f"({' '.join(fact)})" for fact in init_facts(state, form))
    return (f"(define (problem {name or spec.name.replace('_', '-')})\n  (:domain {domain_name(spec, form)})\n"
            f"  (:objects {objects})\n  (:init {facts})\n"
            f"  (:goal (and {' '.join(f'(wiped {s})' for s in segments)})))\n")


def start_problems(spec, form: str = "strips") -> dict[str, str]:
    """Problem name -> problem text for each start of ``spec`` (each layout of a uniform start)."""
    spec = get_task_spec(spec)
    base = spec.name.replace("_", "-")
    if spec.start != StartMode.UNIFORM_UNCLEAN.value:
        return {base: problem_pddl(spec, None, form)}
    layouts = {}
    for state in unclean_layouts(spec.segments, spec.n_objects):
        name = f"{base}-arm{state.arm + 1}-" + "-".join(f"o{j + 1}s{w + 1}" for j, w in enumerate(state.objects))
        layouts[name] = problem_pddl(spec, state, form, name)
    return layouts


def write_pddl(spec, folder, forms=FORMS) -> list[Path]:
    """Write ``domain-<form>.pddl`` and ``<problem>-<form>.pddl`` of every start into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for form in forms:
        texts = {f"domain-{form}": domain_pddl(spec, form)}
        texts.update({f"{name}-{form}": text for name, text in start_problems(spec, form).items()})
        for name, text in texts.items():
            (folder / f"{name}.pddl").write_text(text)
            written.append(folder / f"{name}.pddl")
    return written


# ---------------------------------------------------------------------------------------------
# read back
# ---------------------------------------------------------------------------------------------
class PDDLError(ValueError):
    """A problem that cannot be read back; the message is ``source:line: reason``."""


class _Atom(str):
    line = 0


class _List(list):
    line = 0


_SECTIONS = (":domain", ":requirements", ":objects", ":init", ":goal")
_TOKENS = re.compile(r";[^\n]*|\(|\)|[^\s();]+|\n")


def _tree(text: str, fail) -> _List:
    """The one s-expression of ``text``, each list and atom with its line; ``fail(line, reason)`` raises."""
    line, stack = 1, [_List()]
    for match in _TOKENS.finditer(text):
        token = match.group()
        if token == "\n":
            line += 1
        elif token == "(":
            stack.append(_List())
            stack[-1].line = line
        elif token == ")":
            if len(stack) == 1:
                fail(line, "')' closes nothing")
            done = stack.pop()
            stack[-1].append(done)
        elif not token.startswith(";"):
            atom = _Atom(token.lower())
            atom.line = line
            stack[-1].append(atom)
    if len(stack) > 1:
        fail(stack[-1].line, "'(' is never closed")
    if len(stack[0]) != 1 or not isinstance(stack[0][0], _List):
        fail(1 if not stack[0] else stack[0][-1].line, "expected one '(define (problem NAME) ...)'")
    return stack[0][0]


def read_problem(problem: str | Path, name: str | None = None) -> TaskSpec:
    """The [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] of a problem of the ``tableclean`` domain.

    ``problem`` is a ``.pddl`` path or the problem's text.  Segments are numbered in the order
    ``(:objects ...)`` declares them (their ``next`` facts must form that ring), objects too; an
    object's type is its object type (``item``: a box).  The spec starts in the problem's
    ``(:init ...)`` state (fixed start) and has the paper's four actions.

    Raises:
        PDDLError: ``source:line: reason`` for a malformed or unsupported problem.
    """
    if isinstance(problem, Path) or (isinstance(problem, str) and problem.strip().endswith(".pddl")):
        source = str(problem)
        try:
            text = Path(problem).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise PDDLError(f"{source}: cannot read the problem ({error.__class__.__name__}: {error})") from None
    else:
        source, text = "problem", str(problem)

    def fail(line, reason):
        raise PDDLError(f"{source}:{line}: {reason}")

    tree = _tree(text, fail)
    sections = {}
    if len(tree) < 2 or tree[0] != "define" or not isinstance(tree[1], _List) or len(tree[1]) != 2 \
            or tree[1][0] != "problem" or not isinstance(tree[1][1], str):
        fail(tree.line, "expected '(define (problem NAME) (:domain tableclean) (:objects ...) (:init ...) "
                        "(:goal ...))'")
    for part in tree[2:]:
        if not isinstance(part, _List) or not part or part[0] not in _SECTIONS:
            fail(part.line, f"unsupported section {_show(part)}; allowed: {', '.join(_SECTIONS)}")
        if part[0] in sections:
            fail(part.line, f"{part[0]} given twice")
        sections[part[0]] = part
    for key in (":domain", ":objects", ":init", ":goal"):
        if key not in sections:
            fail(tree.line, f"the problem has no ({key} ...)")
    if list(sections[":domain"][1:]) != [DOMAIN]:
        fail(sections[":domain"].line, f"the domain must be {DOMAIN!r} (the ADL form), got "
                                       f"{_show(sections[':domain'])}")
    segments, items = _objects(sections[":objects"], fail)
    clean, where, arm = {s: False for s in segments}, {}, None
    ring = {(segments[k], segments[(k + 1) % len(segments)]) for k in range(len(segments))}
    signatures = {"arm-at": (SEGMENT,), "next": (SEGMENT, SEGMENT), "on": (ITEM, SEGMENT), "holding": (ITEM,),
                  "wiped": (SEGMENT,)}
    for fact in sections[":init"][1:]:
        if not isinstance(fact, _List) or not fact or fact[0] not in signatures:
            fail(fact.line, f"unsupported fact {_show(fact)}; allowed: "
                            + ", ".join(f"({p} {' '.join(a)})" for p, a in signatures.items()))
        wanted, args = signatures[fact[0]], fact[1:]
        kinds = [SEGMENT if a in segments else ITEM if a in items else None for a in args]
        if len(args) != len(wanted) or kinds != list(wanted):
            fail(fact.line, f"{_show(fact)} must be ({fact[0]} {' '.join(wanted)}) over declared objects")
        if fact[0] == "next" and tuple(args) not in ring:
            fail(fact.line, f"{_show(fact)}: segments are numbered as declared and MOVE goes around the ring "
                            + " ".join(f"(next {a} {b})" for a, b in sorted(ring, key=lambda p: segments.index(p[0]))))
        if fact[0] == "next":
            ring.discard(tuple(args))
        elif fact[0] == "arm-at":
            if arm is not None:
                fail(fact.line, f"the arm is already over {arm}")
            arm = args[0]
        elif fact[0] == "wiped":
            clean[args[0]] = True
        else:
            if args[0] in where:
                fail(fact.line, f"{args[0]} is already placed ({where[args[0]]})")
            if fact[0] == "holding" and HELD in where.values():
                fail(fact.line, "the gripper holds at most one object")
            where[args[0]] = HELD if fact[0] == "holding" else args[1]
    init = sections[":init"].line
    if ring:
        fail(init, "missing " + " ".join(f"(next {a} {b})" for a, b in sorted(ring)))
    if arm is None:
        fail(init, "no (arm-at SEGMENT) fact")
    missing = [o for o in items if o not in where]
    if missing:
        fail(init, f"{', '.join(missing)} neither (on OBJECT SEGMENT) nor held")
    _goal(sections[":goal"], segments, fail)
    state = TaskState(tuple(clean[s] for s in segments),
                      tuple(HELD if where[o] == HELD else segments.index(where[o]) for o in items), segments.index(arm))
    if state.is_terminal:
        fail(init, "every segment is already wiped")
    kinds = tuple(DEFAULT_OBJECT_TYPE if kind == ITEM else kind for kind in items.values())
    try:
        return TaskSpec(name or str(tree[1][1]).replace("-", "_"), segments=len(segments), objects=kinds,
                        start_state=state, description=f"read from the PDDL problem {tree[1][1]}")
    except ValueError as error:
        fail(tree[1].line, str(error))


def _show(node) -> str:
    return f"({' '.join(_show(n) for n in node)})" if isinstance(node, list) else str(node)


def _objects(section: _List, fail) -> tuple[list[str], dict[str, str]]:
    """Segments in order, and object name -> type, of ``(:objects a b - segment c - box ...)``."""
    segments, items, pending = [], {}, []
    words = list(section[1:])
    while words:
        word = words.pop(0)
        if isinstance(word, _List):
            fail(word.line, f"(:objects ...) lists names and '- TYPE', got {_show(word)}")
        if word != "-":
            if word in pending or word in segments or word in items:
                fail(word.line, f"object {word!r} is declared twice")
            pending.append(word)
            continue
        if not words or isinstance(words[0], _List) or not pending:
            fail(word.line, "'-' must follow names and precede a type")
        kind = words.pop(0)
        if kind == SEGMENT:
            segments += pending
        elif NAME_PATTERN.match(kind):
            items.update({name: kind for name in pending})
        else:
            fail(kind.line, f"object type {kind!r} must be lower_snake (an object type, or item)")
        pending = []
    if pending:
        fail(section.line, f"{', '.join(pending)} ha{'s' if len(pending) == 1 else 've'} no type; "
                           "end with '- segment' or '- OBJECT_TYPE'")
    if len(segments) < 2 or not items:
        fail(section.line, f"a problem needs at least 2 segments and 1 object, got {len(segments)} and {len(items)}")
    return segments, items


def _goal(section: _List, segments: list[str], fail) -> None:
    """Refuse any goal but every segment wiped (as ``(and (wiped s1) ...)`` or ``forall``)."""
    goal = section[1] if len(section) == 2 else None
    every = (isinstance(goal, list) and goal and goal[0] == "and"
             and sorted(_show(g) for g in goal[1:]) == sorted(f"(wiped {s})" for s in segments))
    forall = _show(goal).replace(" ", "") in ("(forall(?s-segment)(wiped?s))",)
    if not (every or forall):
        fail(section.line, f"the goal must be every segment wiped: (and {' '.join(f'(wiped {s})' for s in segments)})")


SPEC_FILE_READERS[".pddl"] = read_problem  # get_task_spec reads a .pddl path as a problem
