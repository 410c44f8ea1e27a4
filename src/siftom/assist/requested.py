"""What was asked for, checked against the world: the parts of a request of several things, an
object the world lacks ("bring me a banana"), an object of which nothing is left to bring ("pass
me the milk" with the milk already on the counter), and one decision for several parts.

The observer applies these after the decision rule: the rule values commands, these say when
the words name something the robot cannot or need not bring, and why, in words it can say.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from siftom.assist import phrasing_en
from siftom.assist.decide import Decision, Situation, decline_reason
from siftom.assist.teamvalue import NONE
from siftom.inference.model import Posterior
from siftom.language.record import Mention, Understanding
from siftom.world.commands import RobotCommand
from siftom.world.model import World


def absent(decision: Decision, mention: Mention) -> Decision | None:
    """No action, with a reason naming it, when the target names an object the world lacks
    ("bring me a banana" where there is none); None otherwise."""
    if mention.obj_class is not None or not mention.named:
        return None
    return Decision(decision.rule, NONE, NONE, 0.0, 0.0,
                    reason=f"{phrasing_en.none_here(mention.named)}: the robot does not bring something else instead",
                    declined=phrasing_en.sorry(phrasing_en.none_here(mention.named)))


# Written words (typed, or one transcript given as what was said) slip less than heard ones. A
# target whose words name no object of the world is a slip for one of them or names an object
# that is not here; a slip for object k is as likely as its words' fit to k's names in the slot
# channel, weighed by how likely the person's actions make a request for k. The prior weight of
# "names an object that is not here" against those (docs/understanding.md, "What a word names"):
# between the slips it must keep ("pass me the silver" while the person makes cereal, 6.9e-4;
# "I'd like the lives" at a set table, 3.7e-4) and the objects not here it must decline
# ("scissors" while the person makes cereal, 2.9e-5; "towel", 5e-7), at their geometric middle.
WRITTEN_ABSENT = 1e-4


def action_weights(post: Posterior | None, classes: Sequence[str]) -> np.ndarray | None:
    """P(a request for each class | the person's actions): the joint posterior without what the
    words say of each command, summed over goals and counts; None when there is no joint."""
    j = None if post is None else post.joint
    if j is None or not len(j.commands):
        return None
    la = np.asarray(j.log_joint, dtype=float)
    if j.log_words is not None:
        la = la - np.asarray(j.log_words, dtype=float)[j.cmd_idx]
    if not np.isfinite(la).any():
        return None
    w = np.exp(la - la[np.isfinite(la)].max())
    w[~np.isfinite(w)] = 0.0
    at = {c: i for i, c in enumerate(classes)}
    out = np.zeros(len(classes))
    for k, cmd in enumerate(j.commands):
        i = at.get(str(cmd.obj_class))
        if i is not None:
            out[i] += float(w[j.cmd_idx == k].sum())
    total = float(out.sum())
    return out / total if total > 0.0 else None


def written_absent(u: Understanding, world: World, lexicon: object = None,
                   post: Posterior | None = None) -> Understanding:
    """``u`` with each target whose words name no object of the world read as naming an object
    that is not here, when that is likelier than a slip for one of the world's objects:

        P(not here | words, actions) = A / (A + sum_k P(k | actions) exp(-s max(0, r_k - slack)))

    (A = ``WRITTEN_ABSENT``, r_k the words' phoneme distance to class k's names, s and slack the
    slot channel's, P(k | actions) from ``post``'s joint without the words, :func:`action_weights`;
    without a joint, the best fit alone stands for the sum). Which object a slip was for is the
    posterior's to weigh."""
    from siftom.language.understand import SLOT_SHARPNESS, SLOT_SLACK, namer

    if not any(m.role == "target" and m.obj_class is None and not m.named and m.words for m in u.mentions):
        return u
    nm = namer(tuple(world.classes), lexicon)
    acts = action_weights(post, nm.classes)

    def far(m: Mention) -> bool:
        r = np.asarray(nm.costs(m.words.split()), dtype=float)
        fit = np.exp(-SLOT_SHARPNESS * np.maximum(0.0, r - SLOT_SLACK))
        slip = float(fit.max()) if acts is None else float(acts @ fit)
        return slip < WRITTEN_ABSENT

    targets = [m for m in u.mentions if m.role == "target"]
    unnamed = [m for m in targets if m.obj_class is None and not m.named and m.words]
    if any(m.obj_class is not None or m.named for m in targets) or not all(far(m) for m in unnamed):
        # another target names an object ("bring the plate my way"), or one of the words may be a
        # slip for one ("any chance you could grab the chapel"): the rest are the words around it
        return u
    return dataclasses.replace(u, mentions=tuple(dataclasses.replace(m, named=m.words) if m in unnamed else m
                                                 for m in u.mentions))


def _already_here(decision: Decision, mention: Mention, post: Posterior, world: World, target: int,
                  verb: str) -> tuple[Decision, tuple[RobotCommand, ...]] | None:
    """(no action with the reason, the command understood) when the target names an object of
    the world of which nothing is left to bring ("pass me the milk" with the milk already on the
    counter): the robot says why, and does not bring another object instead; None otherwise."""
    if mention.obj_class is None or post.joint is None or post.joint.state is None:
        return None
    if _names_category_of(mention, str(post.command.obj_class), world):
        return None  # "the spices": the words name the salt as well as the pepper; the posterior chose
    asked = RobotCommand(verb, mention.obj_class, mention.count or 1)
    why = decline_reason(asked, Situation(world, post.joint.state, target))
    if not why:
        return None
    return Decision(decision.rule, NONE, NONE, 0.0, 0.0, reason=f"asked for {asked}, but {why}",
                    declined=phrasing_en.sorry(why)), (asked,)


def said_object(decision: Decision, parts: tuple[RobotCommand, ...], mention: Mention, post: Posterior,
                 world: World, target: int, verb: str) -> tuple[Decision, tuple[RobotCommand, ...]]:
    """The decision and parts once the object the words name is checked: none with the reason
    when nothing of it is left to bring, or when the world lacks it."""
    here = _already_here(decision, mention, post, world, target, verb)
    if here is not None:  # understood, but nothing of it is left to bring: say so
        decision, parts = here
    more = None if here is not None else beyond_supply(decision, mention, post, world, target, verb)
    if more is not None:
        return more
    if post.understanding is not None and (back := taken_back(decision, post.understanding, post, world)) is not None:
        return back, parts
    return absent(decision, mention) or decision, parts


def taken_back(decision: Decision, u: Understanding, post: Posterior, world: World) -> Decision | None:
    """A question instead of carrying out an object the words took back or refused ("bring the
    coffee, scratch that, the tea" with the likelihoods still on the coffee): "Shall I get the
    tea?" when a target names an object of the world, else None (the decision stands)."""
    from siftom.assist.asking import lexicon_of
    from siftom.assist.questions import confirm_question

    if decision.action in (NONE, "ask") or not decision.command or decision.command == NONE:
        return None
    try:
        cls = RobotCommand.parse(decision.command).obj_class
    except ValueError:
        return None
    refused = {m.obj_class for m in u.mentions if m.role in ("negated", "retracted") and m.obj_class}
    wanted = [m.obj_class for m in u.mentions if m.role == "target" and m.obj_class in world.classes]
    if cls not in refused or cls in wanted or not wanted:
        return None
    options = [c for c, _ in post.commands if c.obj_class == wanted[0]]
    if not options:
        return None
    ask = str(options[0])
    q = confirm_question(ask, lexicon_of(world))
    return Decision(decision.rule, "ask", ask, post.prob(ask), float("nan"), q.text, q.options,
                    reason=f"{decision.command} was taken back in the words, which ask for {wanted[0]}: asking first",
                    question_kind=q.kind, asked=q)


def words_refused(post: Posterior) -> tuple[str, ...]:
    """The commands of ``post`` whose object the words negated or took back and did not ask for
    ("not the cheese", "the coffee, scratch that, the tea"): refused for the exchange a question
    opens, so no answer brings them back."""
    u = post.understanding
    if u is None or not u.request:
        return ()
    refused = {m.obj_class for m in u.mentions if m.role in ("negated", "retracted") and m.obj_class}
    refused -= {m.obj_class for m in u.mentions if m.role == "target" and m.obj_class}
    return tuple(str(c) for c, _ in post.commands if c.obj_class in refused)


# rules that ask (the others carry out what there is)
_ASKING_RULES = ("teammate", "ask-or-act")


def beyond_supply(decision: Decision, mention: Mention, post: Posterior, world: World, target: int,
                  verb: str) -> tuple[Decision, tuple[RobotCommand, ...]] | None:
    """More asked for than the world holds ("bring me three pens" where two are left): the
    objects there are, never another object; a rule that asks confirms first ("There are only
    two pens here. Shall I bring both?"). None when the count said is not beyond what is left."""
    from siftom.assist.asking import lexicon_of
    from siftom.assist.decide import left_to_bring
    from siftom.assist.questions import NO, NO_KEYS, YES, YES_KEYS, Question, _noun
    from siftom.likelihood.phrasing import number_word

    if mention.obj_class is None or not mention.count or post.joint is None or post.joint.state is None:
        return None
    where = Situation(world, post.joint.state, target)
    left, _ = left_to_bring(str(RobotCommand(verb, mention.obj_class, 1)), where)
    if not 0 < left < mention.count:
        return None
    cmd = RobotCommand(verb, mention.obj_class, left if verb != "fetch" else 1)
    noun = _noun(RobotCommand(verb, mention.obj_class, left), lexicon_of(world))
    there = f"There is only one {noun}" if left == 1 else f"There are only {number_word(left)} {noun}"
    # a fetch carries one object: of several left, it offers one
    them = "it" if left == 1 else "one of them" if verb == "fetch" else "both" if left == 2 else "them"
    why = f"asked for {mention.count} {mention.obj_class}, {left} left to bring: the ones there are, nothing else"
    if decision.rule not in _ASKING_RULES:
        return Decision(decision.rule, str(cmd), str(cmd), post.prob(str(cmd)), float("nan"), reason=why), (cmd,)
    get = "get" if verb == "fetch" else "bring"
    q = Question("confirm", f"{there} here. Shall I {get} {them}?", (str(cmd),), (YES, NO), (YES_KEYS, NO_KEYS))
    return Decision(decision.rule, "ask", str(cmd), post.prob(str(cmd)), float("nan"), q.text, q.options,
                    reason=f"{why}; asking first", question_kind=q.kind, asked=q), (cmd,)


def _names_category_of(mention: Mention, obj_class: str, world: World) -> bool:
    """Whether the mention's words are a category word that names ``obj_class`` too ("the
    spices": salt and pepper; "the cutlery": forks, knives and spoons)."""
    from siftom.likelihood.lexicon import lexicon_for, pluralize

    if obj_class == mention.obj_class or obj_class not in world.classes:
        return False
    said = mention.words.strip()
    return any(said in (cat.word, pluralize(cat.word)) for cat in lexicon_for(world).categories_of(obj_class))


def request_parts(targets: Sequence[Mention], most: int) -> tuple[list[int], list[Mention]]:
    """(the targets taken as parts of the request, by index; those past ``most``, left out).

    Each part names an object: a slot naming none is one request with the rest ("any chance you
    could grab four knights"), and a repeated object is one part ("the potato ... the potatoes").
    """
    named: list[int] = []
    for k, m in enumerate(targets):
        if (m.obj_class is not None or m.named) and all(
                (targets[i].obj_class, targets[i].named) != (m.obj_class, m.named) for i in named):
            named.append(k)
    return named[:most], [targets[k] for k in named[most:]]


def one_command_once(decisions: Sequence[Decision], parts: tuple[RobotCommand, ...]
                     ) -> tuple[list[Decision], tuple[RobotCommand, ...]]:
    """The parts' decisions with a command carried out for an earlier part not carried out again
    (two slots whose posteriors chose the same object: one request, one fetch)."""
    out: list[Decision] = []
    done: set[str] = set()
    for d in decisions:
        if d.action not in (NONE, "ask") and d.action in done:
            d = Decision(d.rule, NONE, NONE, 0.0, 0.0, reason=f"{d.action} is carried out for another part already")
        elif d.action not in (NONE, "ask"):
            done.add(d.action)
        out.append(d)
    return out, parts


def combine_parts(decisions: Sequence[Decision], left_out: Sequence[Mention] = (), most: int = 0) -> Decision:
    """One decision for a request of several parts: act on the parts the rule acts on (the
    first part's decision carries them), else the first part's ask or none; the reason names
    the objects ``left_out`` (past the ``most`` things one request carries out)."""
    acting = [d for d in decisions if d.action not in (NONE, "ask")]
    decision = decisions[0]
    if acting:
        reason = "; ".join(f"{d.command if d.action not in (NONE, 'ask') else d.action}: {d.reason}"
                           for d in decisions if d.reason)
        # what it turns down of the request it says while carrying out the rest
        said = " ".join(d.declined for d in decisions if d.declined)
        decision = dataclasses.replace(acting[0], reason=reason, declined=said)
    if left_out:
        names = ", ".join(m.obj_class or m.named for m in left_out)
        decision = dataclasses.replace(decision, reason=f"{decision.reason}; not taken this time (at most "
                                       f"{most} things per request): {names}")
    return decision
