"""Natural-language sentences for motion labels, expanded from the grammar in ``grammar.yaml``.

A label is a (dataset, content, style) triple of the Bandai Namco data, e.g.
``("dataset-2", "walk-turn-left", "elderly")``. The grammar (data, not code) gives each content
a set of verb phrases and each style a set of adverbs, phrases and subjects; templates combine
them. Expansion is deterministic and independent of Python's and numpy's random generators
(a SplitMix64 stream seeded from the label), so a sentence list is the same everywhere.

Laterality is exact: left stays left, right stays right, "both" stays both, and contents
without a side never name one, so mirror augmentation (which swaps "left" and "right" in the
content name) always lands on a label whose sentences describe the mirrored motion.
"""

from __future__ import annotations

import hashlib
import itertools
import random
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

GRAMMAR_FILE = "grammar.yaml"

# Template slots. The three verb-form slots share one pool (the content's phrases), so a
# template that uses {v3} and {ving} would use the same phrase in both.
PHRASE_SLOTS = ("v3", "ving", "vb")
STYLE_SLOTS = ("adverb", "post", "attitude", "styled_subject")
ALL_SLOTS = ("subject", *PHRASE_SLOTS, *STYLE_SLOTS)

_VERB = re.compile(r"<([a-z]+)>")
_SLOT = re.compile(r"\{([a-z_0-9]+)\}")
_SIDE = re.compile(r"\b(left|right)(wards?)?\b")
_WORD_SIDE = {"left": re.compile(r"\bleft(wards?)?\b"), "right": re.compile(r"\bright(wards?)?\b")}
_BOTH = re.compile(r"\bboth\b")
_DATASET_PREFIX = re.compile(r"^dataset-(\d+)_")

_MASK64 = (1 << 64) - 1


class GrammarError(ValueError):
    """The grammar file breaks one of its rules; the message names the entry."""


@dataclass(frozen=True, order=True)
class Label:
    """One (dataset, content, style) label with canonical names (style aliases kept as given)."""

    dataset: str
    content: str
    style: str

    def __str__(self) -> str:
        return f"{self.dataset}/{self.content}/{self.style}"


@dataclass(frozen=True)
class Phrase:
    """A content phrase in its three forms."""

    base: str
    third: str
    gerund: str


@dataclass(frozen=True)
class Content:
    name: str
    phrases: tuple[Phrase, ...]
    canonical: Phrase


@dataclass(frozen=True)
class Style:
    name: str
    plain: bool
    genders: tuple[str, ...]
    canonical: str
    adverb: tuple[str, ...]
    post: tuple[str, ...]
    attitude: tuple[str, ...]
    styled_subject: tuple[str, ...]


@dataclass(frozen=True)
class Template:
    index: int
    text: str
    # Pools in order of first use: "subject", "phrase" or a style slot name.
    pools: tuple[str, ...]
    has_style: bool


@dataclass(frozen=True)
class Grammar:
    version: int
    digest: str
    max_sentences_per_label: int
    seed: int
    datasets: dict[str, tuple[tuple[str, ...], tuple[str, ...]]]
    contents: dict[str, Content]
    # Keyed by every name a style goes by (its own and its aliases).
    styles: dict[str, Style]
    templates: tuple[Template, ...]
    neutral_subjects: tuple[str, ...]
    gendered_subjects: dict[str, tuple[str, ...]]
    canonical_subject: str


# ---------------------------------------------------------------------------------------------
# Loading and validation


def _strings(value: object, where: str) -> tuple[str, ...]:
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise GrammarError(f"{where}: expected a list of strings, got {value!r}")
    for v in value:
        if v != v.strip() or "  " in v or not v or v != v.lower():
            raise GrammarError(f"{where}: {v!r} must be lower case, trimmed, single-spaced")
    return tuple(value)


def swap_sides(text: str) -> str:
    """Swap the words left and right (and leftward/rightward) in ``text``."""

    def swap(match: re.Match[str]) -> str:
        side = "right" if match.group(1) == "left" else "left"
        return side + (match.group(2) or "")

    return _SIDE.sub(swap, text)


def sides_in(text: str) -> set[str]:
    """Which of "left", "right" and "both" ``text`` names as words."""
    found = {side for side, pattern in _WORD_SIDE.items() if pattern.search(text)}
    if _BOTH.search(text):
        found.add("both")
    return found


def content_sides(content: str) -> set[str]:
    """The sides a content name names: {"left"}, {"right"}, {"both"} or empty."""
    return {part for part in content.split("-") if part in ("left", "right", "both")}


def mirror_content(content: str) -> str:
    """The content of the mirrored motion: left and right swapped in the name."""
    parts = content.split("-")
    swapped = ["right" if p == "left" else "left" if p == "right" else p for p in parts]
    return "-".join(swapped)


def _conjugate(base: str, verbs: dict[str, tuple[str, str]], where: str) -> Phrase:
    if not _VERB.search(base):
        raise GrammarError(f"{where}: phrase {base!r} marks no verb with <...>")
    for verb in _VERB.findall(base):
        if verb not in verbs:
            raise GrammarError(f"{where}: verb <{verb}> in {base!r} is not listed under `verbs`")
    return Phrase(
        base=_VERB.sub(lambda m: m.group(1), base),
        third=_VERB.sub(lambda m: verbs[m.group(1)][0], base),
        gerund=_VERB.sub(lambda m: verbs[m.group(1)][1], base),
    )


def _check_laterality(content: str, phrases: Sequence[str], where: str) -> None:
    want = content_sides(content)
    for phrase in phrases:
        have = sides_in(phrase)
        # Left and right must match exactly; "both" is mirror-symmetric, so a content without
        # it may still say it (byebye waves both hands), but a "both" content always says it.
        if have - {"both"} != want - {"both"} or ("both" in want and "both" not in have):
            raise GrammarError(
                f"{where}: phrase {phrase!r} names sides {sorted(have)} but content "
                f"{content!r} names {sorted(want)}; laterality must be exact"
            )


def _parse(raw: dict[str, Any], digest: str) -> Grammar:
    verbs_raw = raw.get("verbs") or {}
    verbs: dict[str, tuple[str, str]] = {}
    for base, forms in verbs_raw.items():
        if not (isinstance(forms, list) and len(forms) == 2):
            raise GrammarError(f"verbs.{base}: expected [third person, gerund], got {forms!r}")
        verbs[str(base)] = (str(forms[0]), str(forms[1]))

    contents_raw: dict[str, Any] = raw.get("contents") or {}
    raw_phrases: dict[str, tuple[str, tuple[str, ...]]] = {}
    for name, entry in contents_raw.items():
        if "mirror_of" in entry:
            continue
        where = f"contents.{name}"
        phrases = _strings(entry.get("phrases"), f"{where}.phrases")
        canonical = entry.get("canonical")
        if not phrases:
            raise GrammarError(f"{where}: no phrases")
        if canonical not in phrases:
            raise GrammarError(f"{where}: canonical {canonical!r} is not one of its phrases")
        raw_phrases[name] = (canonical, phrases)
    for name, entry in contents_raw.items():
        if "mirror_of" not in entry:
            continue
        source = entry["mirror_of"]
        if source not in raw_phrases:
            raise GrammarError(f"contents.{name}: mirror_of {source!r} is not a content")
        if mirror_content(source) != name:
            raise GrammarError(f"contents.{name}: is not the mirror of {source!r}")
        canonical, phrases = raw_phrases[source]
        raw_phrases[name] = (swap_sides(canonical), tuple(swap_sides(p) for p in phrases))

    contents: dict[str, Content] = {}
    for name, (canonical, phrases) in raw_phrases.items():
        where = f"contents.{name}"
        _check_laterality(name, phrases, where)
        if len(set(phrases)) != len(phrases):
            raise GrammarError(f"{where}: duplicate phrases")
        conj = tuple(_conjugate(p, verbs, where) for p in phrases)
        contents[name] = Content(name, conj, conj[phrases.index(canonical)])

    subjects_raw = raw.get("subjects") or {}
    neutral = _strings(subjects_raw.get("neutral"), "subjects.neutral")
    gendered = {
        str(g): _strings(v, f"subjects.gendered.{g}")
        for g, v in (subjects_raw.get("gendered") or {}).items()
    }
    canonical_subject = str(raw.get("canonical_subject", ""))
    if canonical_subject not in neutral:
        raise GrammarError(f"canonical_subject {canonical_subject!r} is not a neutral subject")

    styles: dict[str, Style] = {}
    for name, entry in (raw.get("styles") or {}).items():
        where = f"styles.{name}"
        genders = _strings(entry.get("genders"), f"{where}.genders")
        for g in genders:
            if g not in gendered:
                raise GrammarError(f"{where}: gender {g!r} has no subjects.gendered entry")
        style = Style(
            name=str(name),
            plain=bool(entry.get("plain", False)),
            genders=genders,
            canonical=str(entry.get("canonical", "")),
            adverb=_strings(entry.get("adverbs"), f"{where}.adverbs"),
            post=_strings(entry.get("post"), f"{where}.post"),
            attitude=_strings(entry.get("attitude"), f"{where}.attitude"),
            styled_subject=_strings(entry.get("subjects"), f"{where}.subjects"),
        )
        words = (*style.adverb, *style.post, *style.attitude, *style.styled_subject)
        for text in words:
            if sides_in(text):
                raise GrammarError(f"{where}: {text!r} names a side; style words must not")
        if style.canonical and style.canonical not in (*style.adverb, *style.post):
            raise GrammarError(f"{where}: canonical {style.canonical!r} is not an adverb or post")
        if not style.canonical and not style.plain:
            raise GrammarError(f"{where}: only a plain style may have an empty canonical")
        for alias in (str(name), *_strings(entry.get("aliases"), f"{where}.aliases")):
            if alias in styles:
                raise GrammarError(f"{where}: style name {alias!r} is defined twice")
            styles[alias] = style

    templates: list[Template] = []
    for index, text in enumerate(raw.get("templates") or []):
        slots = _SLOT.findall(text)
        unknown = [s for s in slots if s not in ALL_SLOTS]
        if unknown:
            raise GrammarError(f"templates[{index}] {text!r}: unknown slots {unknown}")
        if sum(s in PHRASE_SLOTS for s in slots) != 1:
            raise GrammarError(f"templates[{index}] {text!r}: needs exactly one of {PHRASE_SLOTS}")
        if len(set(slots)) != len(slots):
            raise GrammarError(f"templates[{index}] {text!r}: a slot is used twice")
        pools = tuple("phrase" if s in PHRASE_SLOTS else s for s in slots)
        has_style = any(s in STYLE_SLOTS for s in slots)
        templates.append(Template(index, text, pools, has_style))

    datasets: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {}
    for name, entry in (raw.get("datasets") or {}).items():
        dcontents = tuple(entry.get("contents") or [])
        dstyles = tuple(entry.get("styles") or [])
        for c in dcontents:
            if c not in contents:
                raise GrammarError(f"datasets.{name}: content {c!r} has no contents entry")
            if mirror_content(c) not in dcontents:
                mirror = mirror_content(c)
                raise GrammarError(f"datasets.{name}: mirror {mirror!r} of {c!r} is missing")
        for s in dstyles:
            if s not in styles:
                raise GrammarError(f"datasets.{name}: style {s!r} has no styles entry or alias")
        datasets[str(name)] = (dcontents, dstyles)

    return Grammar(
        version=int(raw.get("version", 0)),
        digest=digest,
        max_sentences_per_label=int(raw.get("max_sentences_per_label", 160)),
        seed=int(raw.get("seed", 0)),
        datasets=datasets,
        contents=contents,
        styles=styles,
        templates=tuple(templates),
        neutral_subjects=neutral,
        gendered_subjects=gendered,
        canonical_subject=canonical_subject,
    )


def load_grammar(path: str | Path | None = None) -> Grammar:
    """Load and validate a grammar file (default: the package's ``grammar.yaml``)."""
    if path is None:
        return _default_grammar()
    data = Path(path).read_bytes()
    return _parse(yaml.safe_load(data), hashlib.sha256(data).hexdigest())


@cache
def _default_grammar() -> Grammar:
    data = resources.files(__package__).joinpath(GRAMMAR_FILE).read_bytes()
    return _parse(yaml.safe_load(data), hashlib.sha256(data).hexdigest())


def grammar_digest() -> str:
    """SHA-256 of the grammar file: caches of embedded sentences record it to detect staleness."""
    return _default_grammar().digest


# ---------------------------------------------------------------------------------------------
# Names


def normalize_dataset(dataset: str | int) -> str:
    """``"dataset-1"``, ``"1"`` or ``1`` -> ``"dataset-1"``; unknown names raise ValueError."""
    grammar = _default_grammar()
    name = str(dataset)
    if name.isdigit():
        name = f"dataset-{name}"
    if name not in grammar.datasets:
        raise ValueError(f"unknown dataset {dataset!r}; expected one of {sorted(grammar.datasets)}")
    return name


def _strip_prefix(name: str) -> str:
    """``"dataset-1_walk"`` (the archives' cfg/*.txt spelling) -> ``"walk"``."""
    return _DATASET_PREFIX.sub("", name)


def resolve_label(dataset: str | int, content: str, style: str) -> Label:
    """Validate a label against the grammar's dataset lists; accepts cfg-style prefixed names."""
    grammar = _default_grammar()
    name = normalize_dataset(dataset)
    contents, styles = grammar.datasets[name]
    content = _strip_prefix(content)
    style = _strip_prefix(style)
    if content not in contents:
        raise ValueError(f"{name} has no content {content!r}; its contents: {', '.join(contents)}")
    if style not in styles:
        raise ValueError(f"{name} has no style {style!r}; its styles: {', '.join(styles)}")
    return Label(name, content, style)


def datasets() -> list[str]:
    return list(_default_grammar().datasets)


def labels(dataset: str | int | None = None) -> list[Label]:
    """Every content x style label of one dataset, or of all datasets (in grammar order)."""
    grammar = _default_grammar()
    names = list(grammar.datasets) if dataset is None else [normalize_dataset(dataset)]
    out: list[Label] = []
    for name in names:
        contents, styles = grammar.datasets[name]
        out.extend(Label(name, c, s) for c in contents for s in styles)
    return out


def mirror_label(label: Label) -> Label:
    """The label of the mirrored clip: left and right swapped in the content."""
    return resolve_label(label.dataset, mirror_content(label.content), label.style)


# ---------------------------------------------------------------------------------------------
# Expansion


class _SplitMix64:
    """A tiny fixed generator, so expansion does not depend on any library's RNG algorithm."""

    def __init__(self, seed: int) -> None:
        self.state = seed & _MASK64

    def next(self) -> int:
        self.state = (self.state + 0x9E3779B97F4A7C15) & _MASK64
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
        return z ^ (z >> 31)

    def below(self, n: int) -> int:
        return self.next() % n


def _permutation(n: int, rng: _SplitMix64) -> Iterator[int]:
    """A lazy Fisher-Yates shuffle of range(n): only the visited positions are stored."""
    moved: dict[int, int] = {}
    for i in range(n):
        j = i + rng.below(n - i)
        at_i = moved.get(i, i)
        at_j = moved.get(j, j)
        moved[j] = at_i
        moved.pop(i, None)
        yield at_j


def _seed(grammar: Grammar, *parts: object) -> int:
    key = "|".join(str(p) for p in (grammar.seed, *parts)).encode()
    return int.from_bytes(hashlib.sha256(key).digest()[:8], "little")


def _render(text: str) -> str:
    text = " ".join(text.split())
    return text.replace(" ,", ",").strip(" ,")


def _template_stream(
    grammar: Grammar,
    template: Template,
    pools: dict[str, tuple[Any, ...]],
    content: Content,
    style: Style,
) -> Iterator[str]:
    sizes = [len(pools[p]) for p in template.pools]
    total = 1
    for size in sizes:
        total *= size
    # A content and its mirror share the seed (and their phrases correspond one to one), so a
    # mirrored label's sentences are exactly the original's with left and right swapped.
    key = min(content.name, mirror_content(content.name))
    rng = _SplitMix64(_seed(grammar, key, style.name, template.index))
    for index in _permutation(total, rng):
        values: dict[str, str] = {}
        rest = index
        for pool, size in zip(reversed(template.pools), reversed(sizes), strict=True):
            rest, digit = divmod(rest, size)
            item = pools[pool][digit]
            if pool == "phrase":
                values.update(v3=item.third, ving=item.gerund, vb=item.base)
            else:
                values[pool] = item
        yield _render(template.text.format(**values))


def _canonical(grammar: Grammar, content: Content, style: Style) -> str:
    return _render(f"{grammar.canonical_subject} {content.canonical.third} {style.canonical}")


@cache
def _expand(content_name: str, style_name: str, cap: int) -> tuple[str, ...]:
    grammar = _default_grammar()
    content = grammar.contents[content_name]
    style = grammar.styles[style_name]
    subjects = grammar.neutral_subjects + tuple(
        itertools.chain.from_iterable(grammar.gendered_subjects[g] for g in style.genders)
    )
    pools: dict[str, tuple[Any, ...]] = {
        "subject": subjects,
        "phrase": content.phrases,
        "adverb": style.adverb,
        "post": style.post,
        "attitude": style.attitude,
        "styled_subject": style.styled_subject,
    }
    streams = [
        _template_stream(grammar, t, pools, content, style)
        for t in grammar.templates
        if (t.has_style or style.plain) and all(pools[p] for p in t.pools)
    ]
    first = _canonical(grammar, content, style)
    out = [first]
    seen = {first}
    while streams and len(out) < cap:
        alive = []
        for stream in streams:
            for sentence in stream:
                if sentence not in seen:
                    seen.add(sentence)
                    out.append(sentence)
                    alive.append(stream)
                    break
            if len(out) >= cap:
                break
        streams = alive
    return tuple(out)


def sentences_for(
    dataset: str | int, content: str, style: str, count: int | None = None
) -> list[str]:
    """All sentences of a label, deterministic; the canonical prompt first.

    ``count`` keeps the first ``count`` (they spread over all templates); ``None`` keeps all
    (``max_sentences_per_label`` of the grammar). Labels that mean the same thing in both
    datasets (same content, same style or style alias) get the same sentences.
    """
    label = resolve_label(dataset, content, style)
    grammar = _default_grammar()
    canonical_style = grammar.styles[label.style].name
    out = list(_expand(label.content, canonical_style, grammar.max_sentences_per_label))
    return out if count is None else out[: max(count, 0)]


def sample_sentence(
    dataset: str | int, content: str, style: str, rng: random.Random | np.random.Generator
) -> str:
    """One sentence of the label, drawn uniformly with ``rng`` (``random.Random`` or numpy)."""
    sentences = sentences_for(dataset, content, style)
    if isinstance(rng, np.random.Generator):
        return sentences[int(rng.integers(len(sentences)))]
    return sentences[rng.randrange(len(sentences))]


def canonical_prompt(content: str, style: str) -> str:
    """The one clear sentence for a content and style (any dataset's name or alias).

    ``canonical_prompt("walk-turn-left", "elderly")`` ->
    ``"a person walks and turns left like an elderly person"``.
    """
    grammar = _default_grammar()
    content = _strip_prefix(content)
    style = _strip_prefix(style)
    if content not in grammar.contents:
        raise ValueError(f"unknown content {content!r}; known: {', '.join(grammar.contents)}")
    if style not in grammar.styles:
        raise ValueError(f"unknown style {style!r}; known: {', '.join(grammar.styles)}")
    return _canonical(grammar, grammar.contents[content], grammar.styles[style])


def all_sentences(dataset: str | int | None = None) -> dict[Label, list[str]]:
    """Every label (of one dataset or all) with all its sentences."""
    return {label: sentences_for(*_astuple(label)) for label in labels(dataset)}


def _astuple(label: Label) -> tuple[str, str, str]:
    return label.dataset, label.content, label.style
