"""A seeded type-confusion mutator for the YAML gates (effects, scenes, studies): the right file with the
wrong kind of value somewhere in it.

The byte mutator (``mutate``) mostly breaks the YAML or a scalar; this one parses a valid seed, picks a
node anywhere in the tree and puts a value of another type there: a list, a mapping, null, a boolean,
a number or a name where something else is expected; wraps a value in a list or a mapping; turns a
mapping into a list or back; gives a mapping a key that is not a string; or drops a key. The result
is valid YAML (``yaml.safe_dump``), so every mutant reaches the loaders' type checks. The same seed
and the same input number give the same bytes.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import yaml

# What a value of the wrong type looks like: empty and filled containers, null, booleans, numbers at the
# edges, and names that are valid somewhere else in the same files.
CONFUSERS: tuple[Any, ...] = (
    None, True, False, 0, -1, 1, 2.5, -0.0, 1e308, -1e308, float("nan"), float("inf"), 10**30,
    "", " ", "x", "x" * 300, "helmet", "memory", "concrete-brick", "kinetic-energy", "rating", "P01",
    [], [None], [True], [1, 2], ["helmet"], ["memory"], [[]], [{}], {}, {"a": 1}, {"type": "memory"},
    {"effect": None}, {1: 2}, {None: None}, {True: []}, {"x": {"y": [{}]}},
)
NON_STRING_KEYS: tuple[Any, ...] = (None, True, False, 0, 1, -1, 2.5)


def _nodes(node: Any, path: tuple = ()) -> list[tuple]:
    """The path of every node under ``node`` (``node`` itself first)."""
    out = [path]
    if isinstance(node, dict):
        for key, value in node.items():
            out += _nodes(value, (*path, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            out += _nodes(value, (*path, i))
    return out


def _get(tree: Any, path: tuple) -> Any:
    for step in path:
        tree = tree[step]
    return tree


def _set(tree: Any, path: tuple, value: Any) -> Any:
    """``tree`` with the node at ``path`` replaced by ``value`` (the new root where ``path`` is empty)."""
    if not path:
        return value
    _get(tree, path[:-1])[path[-1]] = value
    return tree


def _pick(rng: np.random.Generator, options) -> Any:
    return copy.deepcopy(options[int(rng.integers(0, len(options)))])


def confuse_tree(tree: Any, rng: np.random.Generator) -> Any:
    """One to three type confusions applied to (a copy of) ``tree``."""
    tree = copy.deepcopy(tree)
    for _ in range(int(rng.integers(1, 4))):
        paths = _nodes(tree)
        path = paths[int(rng.integers(0, len(paths)))]
        node = _get(tree, path)
        op = int(rng.integers(0, 7))
        if op <= 2:  # a value of another type (the most common confusion)
            tree = _set(tree, path, _pick(rng, CONFUSERS))
        elif op == 3:  # the value wrapped in a list, or in a mapping
            tree = _set(tree, path, [node] if rng.integers(0, 2) else {"value": node})
        elif op == 4:  # a mapping as a list of its values (or of its keys), a list as a mapping
            if isinstance(node, dict):
                tree = _set(tree, path, list(node.values()) if rng.integers(0, 2) else list(node))
            elif isinstance(node, list):
                tree = _set(tree, path, {f"k{i}": v for i, v in enumerate(node)})
            else:
                tree = _set(tree, path, _pick(rng, CONFUSERS))
        elif op == 5 and isinstance(node, dict) and node:  # a key that is not a string
            keys = list(node)
            key = keys[int(rng.integers(0, len(keys)))]
            node[_pick(rng, NON_STRING_KEYS)] = node.pop(key)
        elif isinstance(node, dict) and node:  # a key dropped
            keys = list(node)
            del node[keys[int(rng.integers(0, len(keys)))]]
        else:
            tree = _set(tree, path, _pick(rng, CONFUSERS))
    return tree


def confuse(seed: bytes, rng: np.random.Generator) -> bytes:
    """One type-confused mutant of the YAML document ``seed``."""
    return yaml.safe_dump(confuse_tree(yaml.safe_load(seed), rng), sort_keys=False, allow_unicode=True).encode()
