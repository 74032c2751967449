"""What the SDK shape checks (check_shapes.py, check_batch_shapes.py) share: the list of
problems found, the checks of a body against an SDK type, and the exit with the problems.
"""

import json
import sys
import typing

import pydantic
from google.genai import types as gtypes

problems = []


def read_input():
    """The JSON object the Rust test writes to stdin."""
    return json.load(sys.stdin)


def typed_dict(kind, td, body, where):
    """A request body against a TypedDict: known keys only, each of the right type."""
    known = set(typing.get_type_hints(td))
    for key in body:
        if key not in known:
            problems.append(f"{where}: `{key}` is not a {kind} field")
    try:
        pydantic.TypeAdapter(td).validate_python(body)
    except pydantic.ValidationError as e:
        problems.append(f"{where}: {e}")


def model(cls, value, where):
    """A reply against a pydantic model; the parsed value, or None after noting the problem."""
    try:
        return cls.model_validate(value)
    except pydantic.ValidationError as e:
        problems.append(f"{where}: {e}")
        return None


def gemini_request(body, where, what):
    """A Gemini generateContent request: `contents` and `generationConfig` only (else an
    unexpected `what`), each of the SDK's types."""
    for key in body:
        if key not in ("contents", "generationConfig"):
            problems.append(f"{where}: unexpected {what} `{key}`")
    for c in body["contents"]:
        model(gtypes.Content, c, where)
    model(gtypes.GenerationConfig, body.get("generationConfig", {}), where)


def finish():
    """Prints one line per problem and exits 1 when there is any."""
    for p in problems:
        print(p)
    sys.exit(1 if problems else 0)
