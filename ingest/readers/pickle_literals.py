"""Plain values out of a pickle, without unpickling it.

PyTables stores a Python attribute that is not a string or a number (pandas' column lists,
``non_index_axes``, ``info``) as a pickle, and unpickles it when the attribute is read: a
pickle names any function and calls it, so reading such a file runs whatever it says.
:func:`literal` reads only the pickle opcodes that build plain values (None, bool, int,
float, str, bytes, tuple, list, dict, set) with :func:`pickletools.genops`, which parses
and never executes; an opcode that imports or calls anything (``GLOBAL``, ``REDUCE``,
``BUILD``, ``INST``, ``OBJ``, ``NEWOBJ``, ...) is refused, so nothing in the file runs.
"""

from __future__ import annotations

import pickletools

from trebuchet.core.errors import TrebuchetInputError

#: Largest pickle read (bytes): pandas' attributes are a few kB even for many columns.
MAX_PICKLE_BYTES = 16 << 20

_MARK = object()

_PUSH = {
    "NONE": lambda arg: None, "NEWTRUE": lambda arg: True, "NEWFALSE": lambda arg: False,
    "EMPTY_LIST": lambda arg: [], "EMPTY_DICT": lambda arg: {}, "EMPTY_TUPLE": lambda arg: (),
    "EMPTY_SET": lambda arg: set(),
}
_VALUE = frozenset({
    "INT", "BININT", "BININT1", "BININT2", "LONG", "LONG1", "LONG4", "FLOAT", "BINFLOAT",
    "STRING", "BINSTRING", "SHORT_BINSTRING", "UNICODE", "BINUNICODE", "SHORT_BINUNICODE",
    "BINUNICODE8", "BINBYTES", "SHORT_BINBYTES", "BINBYTES8",
})
_IGNORED = frozenset({"PROTO", "FRAME"})


def literal(data: bytes, what: str) -> object:
    """The plain value pickled in ``data``; :class:`TrebuchetInputError` naming ``what`` for
    a pickle that would import or call anything, or that is no pickle."""
    if len(data) > MAX_PICKLE_BYTES:
        raise TrebuchetInputError.at(what, f"a pickle of {len(data)} bytes, more than the "
                                     f"{MAX_PICKLE_BYTES >> 20} MiB a table's names take")
    stack: list = []
    memo: dict = {}
    try:
        for op, arg, _ in pickletools.genops(data):
            name = op.name
            if name in _IGNORED:
                continue
            if name == "STOP":
                if len(stack) != 1 or stack[0] is _MARK:
                    raise ValueError("unbalanced pickle")
                return stack[0]
            if name in _VALUE:
                stack.append(arg)
            elif name in _PUSH:
                stack.append(_PUSH[name](arg))
            else:
                _structure(name, arg, stack, memo, what)
    except TrebuchetInputError:
        raise
    except (ValueError, IndexError, KeyError, TypeError, AttributeError, OverflowError) as exc:
        raise TrebuchetInputError.at(what, f"not a readable pickle of names ({exc})") from None
    raise TrebuchetInputError.at(what, "not a readable pickle of names (no end)")


def _pop_mark(stack: list) -> list:
    """The items above the topmost mark, the mark removed."""
    k = len(stack) - 1 - stack[::-1].index(_MARK)
    items = stack[k + 1:]
    del stack[k:]
    return items


def _structure(name: str, arg: object, stack: list, memo: dict, what: str) -> None:
    """The opcodes that build containers, mark, memoise; anything else is refused."""
    if name == "MARK":
        stack.append(_MARK)
    elif name in ("LIST", "TUPLE", "DICT", "FROZENSET"):
        items = _pop_mark(stack)
        if name == "LIST":
            stack.append(items)
        elif name == "TUPLE":
            stack.append(tuple(items))
        elif name == "FROZENSET":
            stack.append(frozenset(items))
        else:
            stack.append(dict(zip(items[::2], items[1::2], strict=True)))
    elif name in ("TUPLE1", "TUPLE2", "TUPLE3"):
        n = int(name[-1])
        items = stack[-n:]
        del stack[-n:]
        stack.append(tuple(items))
    elif name == "APPEND":
        value = stack.pop()
        stack[-1].append(value)
    elif name == "APPENDS":
        items = _pop_mark(stack)
        stack[-1].extend(items)
    elif name == "SETITEM":
        value, key = stack.pop(), stack.pop()
        stack[-1][key] = value
    elif name == "SETITEMS":
        items = _pop_mark(stack)
        stack[-1].update(zip(items[::2], items[1::2], strict=True))
    elif name == "ADDITEMS":
        items = _pop_mark(stack)
        stack[-1].update(items)
    elif name in ("PUT", "BINPUT", "LONG_BINPUT"):
        memo[arg] = stack[-1]
    elif name == "MEMOIZE":
        memo[len(memo)] = stack[-1]
    elif name in ("GET", "BINGET", "LONG_BINGET"):
        stack.append(memo[arg])
    elif name == "POP":
        stack.pop()
    elif name == "POP_MARK":
        _pop_mark(stack)
    elif name == "DUP":
        stack.append(stack[-1])
    else:
        shown = f" {arg!r}"[:60] if arg is not None else ""
        raise TrebuchetInputError.at(
            what, f"holds a pickled Python object (opcode {name}{shown}), not plain names: "
            "it is not read, since unpickling it would run code from the file")
