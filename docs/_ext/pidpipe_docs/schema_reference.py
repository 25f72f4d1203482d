"""The configuration reference, written from the JSON schema that validates the config.

:func:`schema_keys` walks ``workflow/schemas/config.schema.yaml`` (local ``$ref``s resolved,
the referring node's own keys taking precedence) and yields one :class:`Key` per named property,
nested objects, array items (``pairs[].friction``) and maps of named objects
(``materials.<name>.density_kg_m3``) included. :func:`schema_to_markdown` renders them as the
page ``reference/generated/config.md``: each key's path, description, type, bounds and default.
Because the page is made from the schema at every build, the documentation cannot disagree
with the validation.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any, Iterator

#: Schema keywords rendered as bounds, with the text that precedes the value.
BOUND_WORDS: tuple[tuple[str, str], ...] = (
    ("minimum", ">= "),
    ("exclusiveMinimum", "> "),
    ("maximum", "<= "),
    ("exclusiveMaximum", "< "),
    ("minItems", "at least {} items"),
    ("maxItems", "at most {} items"),
    ("minProperties", "at least {} entries"),
    ("minLength", "at least {} characters"),
    ("maxLength", "at most {} characters"),
)


@dataclass(frozen=True)
class Key:
    """One configuration key as the schema defines it.

    Attributes
    ----------
    path : str
        Dotted path from the top of the config; ``[]`` marks an array's items and ``<name>``
        an entry of a map whose names the user chooses.
    node : dict
        The key's schema node with its ``$ref`` resolved.
    required : bool
        Whether the enclosing object requires the key.
    depth : int
        Named keys above it (0 for a top-level key).
    """

    path: str
    node: dict = field(repr=False)
    required: bool = False
    depth: int = 0

    @property
    def description(self) -> str:
        """The schema's description, whitespace folded ('' when there is none)."""
        return " ".join(str(self.node.get("description", "")).split())

    @property
    def type(self) -> str:
        """The JSON type(s), 'a or b' for a list of types; enum values are shown as bounds."""
        kind = self.node.get("type")
        if kind is None:
            kind = "object" if "properties" in self.node else ("enum" if "enum" in self.node else "any")
        if isinstance(kind, list):
            return " or ".join(str(k) for k in kind)
        if kind == "array" and isinstance(self.node.get("items"), dict):
            item = self.node["items"].get("type")
            if isinstance(item, str):
                return f"array of {item}"
        return str(kind)

    @property
    def bounds(self) -> list[str]:
        """Bounds of the value and, for an array of scalars, of its items."""
        out = _bounds(self.node)
        items = self.node.get("items")
        if isinstance(items, dict) and items.get("type") != "object" and "properties" not in items:
            out += [f"each item {text}" for text in _bounds(items)]
        if self.node.get("uniqueItems"):
            out.append("no item twice")
        return out

    @property
    def default(self) -> str | None:
        """The default as compact JSON, None when the schema gives none."""
        if "default" not in self.node:
            return None
        return json.dumps(self.node["default"], ensure_ascii=False)


def _bounds(node: dict) -> list[str]:
    out = []
    for word, text in BOUND_WORDS:
        if word in node:
            out.append(text.format(node[word]) if "{}" in text else f"{text}{node[word]}")
    if "enum" in node:
        out.append("one of " + ", ".join(f"`{json.dumps(v)}`" for v in node["enum"]))
    if "pattern" in node:
        out.append(f"matches `{node['pattern']}`")
    return out


def resolve(node: dict, root: dict) -> dict:
    """``node`` with a local ``$ref`` replaced by its target; the node's own keys win.

    Parameters
    ----------
    node : dict
        A schema node, possibly with ``$ref: "#/$defs/..."``.
    root : dict
        The whole schema (where the reference points).

    Returns
    -------
    dict
        A new dict; nested references are resolved too.
    """
    if not isinstance(node, dict) or "$ref" not in node:
        return node
    ref = node["$ref"]
    if not ref.startswith("#/"):
        raise ValueError(f"only local references are supported, not {ref!r}")
    target: Any = root
    for part in ref[2:].split("/"):
        target = target[part]
    merged = dict(resolve(target, root))
    merged.update({k: v for k, v in node.items() if k != "$ref"})
    return merged


def schema_keys(schema: dict) -> Iterator[Key]:
    """Every named key of the schema, depth first, in the schema's order.

    Parameters
    ----------
    schema : dict
        A JSON schema (draft 2020-12) whose top is an object with ``properties``.

    Yields
    ------
    Key
    """
    yield from _walk(schema, schema, "", 0)


def _walk(node: dict, root: dict, prefix: str, depth: int) -> Iterator[Key]:
    node = resolve(node, root)
    required = set(node.get("required", ()))
    for name, child in node.get("properties", {}).items():
        child = resolve(child, root)
        path = f"{prefix}.{name}" if prefix else name
        yield Key(path, child, name in required, depth)
        yield from _children(child, root, path, depth + 1)


def _children(node: dict, root: dict, path: str, depth: int) -> Iterator[Key]:
    if "properties" in node:
        yield from _walk(node, root, path, depth)
    extra = node.get("additionalProperties")
    if isinstance(extra, dict):
        extra = resolve(extra, root)
        if "properties" in extra:
            yield from _walk(extra, root, f"{path}.<name>", depth)
    items = node.get("items")
    if isinstance(items, dict):
        items = resolve(items, root)
        if "properties" in items:
            yield from _walk(items, root, f"{path}[]", depth)


def undescribed(schema: dict) -> list[str]:
    """Paths of the keys that have no description in the schema."""
    return [key.path for key in schema_keys(schema) if not key.description]


def escape(text: str) -> str:
    """``text`` with the characters that Markdown (and MyST's dollar math) would read escaped."""
    return re.sub(r"([\\`*<>\[\]$|#])", r"\\\1", text)


def label(path: str) -> str:
    """The Sphinx label of a key's section: ``config-`` and the path, punctuation as '-'."""
    text = "".join(c if c.isalnum() or c == "_" else "-" for c in path)
    return "config-" + "-".join(part for part in text.split("-") if part)


#: Marks a key that a config does not set.
ABSENT = object()


def configured_value(config: dict | None, path: str):
    """The value ``config`` gives the key at ``path``, or :data:`ABSENT` (also for paths
    through lists ``[]`` or user-named entries ``<name>``)."""
    if config is None or "[]" in path or "<name>" in path:
        return ABSENT
    value = config
    for part in path.split("."):
        if not isinstance(value, dict) or part not in value:
            return ABSENT
        value = value[part]
    return value


def schema_to_markdown(schema: dict, source: str = "workflow/schemas/config.schema.yaml",
                       config: dict | None = None, config_name: str = "config.yaml") -> str:
    """The configuration reference page, in MyST Markdown.

    Parameters
    ----------
    schema : dict
        The config's JSON schema.
    source : str
        The schema's path, named on the page.
    config : dict, optional
        A config (the default campaign's): where it sets a scalar or list key to a value other
        than the default, the page shows that value too.
    config_name : str
        The config's file name, as the page names it.

    Returns
    -------
    str
        One section per top-level key and one sub-section per nested key, each with the
        key's description, type, bounds, default and whether it is required. A key without a
        description says so.
    """
    lines = [
        "# Configuration keys",
        "",
        f"Generated from `{source}` at every build of these pages: the same schema validates",
        "`config.yaml` before anything runs, so this list and the validation cannot disagree.",
        "Keys left out of a config take the default shown. `[]` marks the items of a list,",
        "`<name>` an entry whose name you choose. Where the default campaign's `config.yaml` sets",
        "a key to another value than the default, that value is shown too.",
        "",
    ]
    if schema.get("description"):
        lines += [escape(" ".join(str(schema["description"]).split())), ""]
    for key in schema_keys(schema):
        level = "#" * min(2 + key.depth, 6)
        lines += [f"({label(key.path)})=", f"{level} `{key.path}`", ""]
        lines += [escape(key.description) if key.description else "*(no description in the schema)*", ""]
        facts = [f"type: {key.type}"]
        if key.bounds:
            facts.append("bounds: " + "; ".join(key.bounds))
        if key.default is not None:
            facts.append(f"default: `{key.default}`")
        value = configured_value(config, key.path)
        if value is not ABSENT and not isinstance(value, dict) and (
                "default" not in key.node or value != key.node["default"]):
            facts.append(f"`{config_name}` sets: `{json.dumps(value, ensure_ascii=False)}`")
        if key.required:
            facts.append("required")
        lines += [f"- {fact}" for fact in facts] + [""]
    return "\n".join(lines)
