"""Check Revelio's request bodies and the reply fixtures its parsers are tested with against the
official SDKs' types (openai, anthropic, google-genai). Reads one JSON object on stdin:

    {"openai": {"requests": [...], "responses": [...]}, "anthropic": {...}, "gemini": {...},
     "gemini_blocking": ["SAFETY", ...]}

Prints one line per problem and exits 1 when there is any.
"""

from anthropic.types import Message, message_create_params
from google.genai import types as gtypes
from openai.types.chat import ChatCompletion, completion_create_params

from shapes import finish, gemini_request, model, problems, read_input, typed_dict


def exact_enum(enum, value, where):
    """The SDK's enums accept any case; the API documents the exact values."""
    if value not in [e.value for e in enum]:
        problems.append(f"{where}: `{value}` is not one of {[e.value for e in enum]}")


data = read_input()

for i, body in enumerate(data["openai"]["requests"]):
    typed_dict("Chat Completions request", completion_create_params.CompletionCreateParamsNonStreaming, body, f"openai request {i}")
for i, body in enumerate(data["openai"]["responses"]):
    model(ChatCompletion, body, f"openai response {i}")

for i, body in enumerate(data["anthropic"]["requests"]):
    typed_dict("Messages request", message_create_params.MessageCreateParamsNonStreaming, body, f"anthropic request {i}")
for i, body in enumerate(data["anthropic"]["responses"]):
    model(Message, body, f"anthropic response {i}")

for i, body in enumerate(data["gemini"]["requests"]):
    where = f"gemini request {i}"
    gemini_request(body, where, "top-level field")
    config = body.get("generationConfig", {})
    level = config.get("thinkingConfig", {}).get("thinkingLevel")
    if level is not None:
        exact_enum(gtypes.ThinkingLevel, level, where)
for i, body in enumerate(data["gemini"]["responses"]):
    model(gtypes.GenerateContentResponse, body, f"gemini response {i}")
for reason in data["gemini_blocking"]:
    known = [e.value for e in gtypes.FinishReason] + [e.value for e in gtypes.BlockedReason]
    if reason not in known:
        problems.append(f"gemini: blocking reason `{reason}` is no FinishReason or BlockedReason")

finish()
