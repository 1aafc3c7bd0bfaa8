"""The one YAML loader of ur5fault: safe, strict and bounded.

Every YAML file the package reads (robot parameters, run configurations, campaigns, model
overlays) goes through :func:`read_yaml` or :func:`loads`, which differ from ``yaml.safe_load`` in:

- **duplicate keys are an error** (PyYAML keeps the last one silently), naming the key and line;
- **numbers as YAML 1.2 reads them**: ``1e9``, ``6.7e4`` and ``-1E3`` are floats (YAML 1.1 reads
  them as strings), ``010`` is ten (not octal eight), ``1:30`` is a string (not 90); ``0x``/``0o``
  prefixes, ``.inf`` and ``.nan`` keep their meaning; ``yes``/``no`` stay booleans;
- **bounded**: documents above :data:`MAX_BYTES` are refused before parsing, and a document whose
  aliases would expand to more than :data:`MAX_NODES` nodes (an "alias bomb": a few hundred bytes
  that expand to gigabytes when walked), a recursive alias or nesting deeper than the parser's
  recursion limit is refused after composing and before constructing any value;
- **an empty file is an error** (it is almost always a mistake, never "use the defaults").

Every failure is a :class:`~ur5fault.errors.ConfigFileError` with a one-line message.

The one YAML writer is :func:`dump`: ``yaml.safe_dump`` of :func:`plain` data, so that numbers taken from numpy
(``np.float64(0.1)``, ``np.int64(3)``, ``np.bool_``) are written as the plain YAML numbers and booleans they are,
not refused by the safe dumper (nor written with a ``!!python/object`` tag a safe loader cannot read).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from ..errors import ConfigFileError, ParameterError
from .checks import short

#: largest YAML document read [bytes]; ur5fault's own files are below 10 kB (assumption: a
#: configuration 100 times larger than any real one is a mistake, not a configuration)
MAX_BYTES = 1 << 20
#: largest number of nodes after alias expansion; the default campaign has about 60
MAX_NODES = 100_000
#: deepest nesting of flow collections ``[...]``/``{...}`` (PyYAML's scanner takes time quadratic
#: in it: 3000 levels cost 1.4 s) and of indented blocks (PyYAML composes them recursively);
#: ur5fault's files nest 3 deep
MAX_DEPTH = 64

_FLOAT = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*\.[0-9_]*|\.[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)?
                     |[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+
                     |[-+]?\.(?:inf|Inf|INF)
                     |\.(?:nan|NaN|NAN))$""", re.X)
_INT = re.compile(r"^(?:[-+]?[0-9][0-9_]*|0o[0-7_]+|0x[0-9a-fA-F_]+)$")


class StrictLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` with YAML 1.2 numbers, duplicate keys refused and alias expansion capped."""

    yaml_implicit_resolvers = {
        first: [(tag, rx) for tag, rx in resolvers
                if tag not in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }

    def compose_document(self) -> Node:
        node = super().compose_document()
        _check_expansion(node)
        return node

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge" or not isinstance(key_node, ScalarNode):
                continue  # merge keys may be overridden; unhashable keys are refused by PyYAML
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise ConfigFileError(f"line {line}: duplicate key {key!r} (first at line {seen[key]})")
            seen[key] = line
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node: ScalarNode) -> int:
        text = str(self.construct_scalar(node)).replace("_", "")
        if text.startswith("0o"):
            return int(text[2:], 8)
        if text.startswith("0x"):
            return int(text[2:], 16)
        return int(text, 10)


StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+.0123456789"))
StrictLoader.add_implicit_resolver("tag:yaml.org,2002:int", _INT, list("-+0123456789"))
StrictLoader.add_constructor("tag:yaml.org,2002:int", StrictLoader.construct_yaml_int)


def _check_expansion(root: Node | None) -> None:
    """Refuse a node graph that expands to more than MAX_NODES nodes, or that contains itself."""
    if root is None:
        return
    size: dict[int, int] = {}
    open_: set[int] = set()
    reused: list[int] = []

    def count(node: Node) -> int:
        key = id(node)
        if key in size:
            reused.append(key)
            return size[key]
        if key in open_:
            raise ConfigFileError(f"line {node.start_mark.line + 1}: recursive alias (a node that contains itself)")
        open_.add(key)
        total = 1
        if isinstance(node, SequenceNode):
            children: list[Node] = list(node.value)
        elif isinstance(node, MappingNode):
            children = [n for pair in node.value for n in pair]
        else:
            children = []
        for child in children:
            total += count(child)
            if total > MAX_NODES:
                what = ("aliases expand to" if reused else "the document holds")  # reused: an alias repeated a node
                raise ConfigFileError(f"{what} more than {MAX_NODES} values; a configuration file this large is "
                                      "refused (split it, or write the list in a campaign sweep)")
        open_.discard(key)
        size[key] = total
        return total

    count(root)


def _flow_depth(text: str) -> int:
    """Deepest nesting of ``[``/``{`` outside quotes and comments (an upper bound for YAML's)."""
    depth = deepest = 0
    quote = ""
    comment = False
    prev = "\n"
    for ch in text:
        if comment:
            comment = ch != "\n"
        elif quote:
            if ch == quote:
                quote = ""
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and prev in " \t\n":
            comment = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
        prev = ch
    return deepest


def _block_depth(text: str) -> int:
    """Deepest nesting of indentation levels (lines that are blank or comments ignored)."""
    stack: list[int] = []
    deepest = 0
    for line in text.splitlines():
        body = line.lstrip(" ")
        if not body or body.startswith("#"):
            continue
        indent = len(line) - len(body)
        while stack and stack[-1] >= indent:
            stack.pop()
        stack.append(indent)
        deepest = max(deepest, len(stack))
    return deepest


def loads(text: str, where: str = "YAML", *, allow_empty: bool = False) -> Any:
    """Parse one YAML document strictly (see the module docstring); ``where`` prefixes errors."""
    if len(text) > MAX_BYTES:
        raise ConfigFileError(f"{where}: {len(text)} characters, above the limit of {MAX_BYTES} for a YAML file")
    if _flow_depth(text) > MAX_DEPTH:
        raise ConfigFileError(f"{where}: YAML nested too deeply (more than {MAX_DEPTH} levels of [ or {{)")
    if _block_depth(text) > MAX_DEPTH:
        raise ConfigFileError(f"{where}: YAML nested too deeply (more than {MAX_DEPTH} levels of indentation)")
    try:
        data = yaml.load(text, Loader=StrictLoader)  # noqa: S506 - StrictLoader derives from SafeLoader
    except ConfigFileError as exc:
        raise ConfigFileError(f"{where}: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        loc = f" line {mark.line + 1}" if mark is not None else ""
        problem = " ".join(str(getattr(exc, "problem", None) or exc).split())
        raise ConfigFileError(f"{where}:{loc} is not valid YAML ({problem})") from None
    except RecursionError:
        raise ConfigFileError(f"{where}: YAML nested too deeply") from None
    if data is None and not allow_empty:
        raise ConfigFileError(f"{where}: the file is empty (no YAML document)")
    return data


def read_yaml(path: str | Path, *, allow_empty: bool = False) -> dict[str, Any]:
    """Read a YAML file whose top level is a mapping.

    Raises:
        ConfigFileError: unreadable, not UTF-8, too large, not valid YAML, duplicate key, alias
            bomb, empty (unless ``allow_empty``), or not a mapping at the top level.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        raw = path.read_bytes() if size <= MAX_BYTES else b""
    except OSError as exc:
        raise ConfigFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if size > MAX_BYTES:
        raise ConfigFileError(f"{path}: {size} bytes, above the limit of {MAX_BYTES} for a YAML file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigFileError(f"{path}: not UTF-8 text (byte {exc.start}); is it a YAML file?") from None
    data = loads(text, str(path), allow_empty=allow_empty)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigFileError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


def plain(data: Any) -> Any:
    """``data`` with numpy scalars made the Python numbers, booleans and strings they hold, numpy arrays and
    tuples made lists and mappings dicts (recursively); everything else as it is."""
    if isinstance(data, Mapping):
        return {(k.item() if isinstance(k, np.generic) else k): plain(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [plain(v) for v in data]
    if isinstance(data, np.ndarray):
        return plain(data.tolist())
    if isinstance(data, np.generic):
        return data.item()
    return data


def dump(data: Any, where: str = "YAML", **kwargs: Any) -> str:
    """``yaml.safe_dump(plain(data), **kwargs)``; a value YAML cannot write as plain data (an object, a path) is
    refused naming ``where``, the value and what can be written."""
    try:
        return yaml.safe_dump(plain(data), **kwargs)
    except yaml.representer.RepresenterError as exc:
        bad = exc.args[1] if len(exc.args) > 1 else None
        raise ParameterError(f"{where}: cannot write {short(bad)} ({type(bad).__name__}) as YAML; give numbers, "
                             "text, true/false, lists and mappings") from None
