"""Check Revelio's request bodies and the reply fixtures its parsers are tested with against the
official SDKs' types (openai, anthropic, google-genai). Reads one JSON object on stdin:

    {"openai": {"requests": [...], "responses": [...]}, "anthropic": {...}, "gemini": {...},
     "gemini_blocking": ["SAFETY", ...]}

Prints one line per problem and exits 1 when there is any.
"""

import json
import sys
import typing

import pydantic
from anthropic.types import Message, message_create_params
from google.genai import types as gtypes
from openai.types.chat import ChatCompletion, completion_create_params

problems = []


def typed_dict(kind, td, body, where):
    """A request body against a TypedDict: known keys only, each of the right type."""
    known = set(typing.get_type_hints(td))
    for key in body:
        if key not in known:
            problems.append(f"{where}: `{key}` is not a {kind} request field")
    try:
        pydantic.TypeAdapter(td).validate_python(body)
    except pydantic.ValidationError as e:
        problems.append(f"{where}: {e}")


def model(cls, value, where):
    try:
        cls.model_validate(value)
    except pydantic.ValidationError as e:
        problems.append(f"{where}: {e}")


def exact_enum(enum, value, where):
    """The SDK's enums accept any case; the API documents the exact values."""
    if value not in [e.value for e in enum]:
        problems.append(f"{where}: `{value}` is not one of {[e.value for e in enum]}")


data = json.load(sys.stdin)

for i, body in enumerate(data["openai"]["requests"]):
    typed_dict("Chat Completions", completion_create_params.CompletionCreateParamsNonStreaming, body, f"openai request {i}")
for i, body in enumerate(data["openai"]["responses"]):
    model(ChatCompletion, body, f"openai response {i}")

for i, body in enumerate(data["anthropic"]["requests"]):
    typed_dict("Messages", message_create_params.MessageCreateParamsNonStreaming, body, f"anthropic request {i}")
for i, body in enumerate(data["anthropic"]["responses"]):
    model(Message, body, f"anthropic response {i}")

for i, body in enumerate(data["gemini"]["requests"]):
    where = f"gemini request {i}"
    for key in body:
        if key not in ("contents", "generationConfig"):
            problems.append(f"{where}: unexpected top-level field `{key}`")
    for c in body["contents"]:
        model(gtypes.Content, c, where)
    config = body.get("generationConfig", {})
    model(gtypes.GenerationConfig, config, where)
    level = config.get("thinkingConfig", {}).get("thinkingLevel")
    if level is not None:
        exact_enum(gtypes.ThinkingLevel, level, where)
for i, body in enumerate(data["gemini"]["responses"]):
    model(gtypes.GenerateContentResponse, body, f"gemini response {i}")
for reason in data["gemini_blocking"]:
    known = [e.value for e in gtypes.FinishReason] + [e.value for e in gtypes.BlockedReason]
    if reason not in known:
        problems.append(f"gemini: blocking reason `{reason}` is no FinishReason or BlockedReason")

for p in problems:
    print(p)
sys.exit(1 if problems else 0)
