"""Check the batch requests Revelio sends and the batch replies its mocks serve (tests/batch.rs)
against the official SDKs' types (openai, anthropic, google-genai). Reads one JSON object on
stdin:

    {"openai": {"sent": [...], "served": [...]}, "anthropic": {...}, "gemini": {...}}

`sent`: OpenAI's uploads (`{"purpose", "lines"}`) and create bodies (`{"create"}`); the
Anthropic and Gemini create bodies. `served`: status replies, file objects and result lines.
Prints one line per problem and exits 1 when there is any.
"""

import typing

from anthropic.types import Message, message_create_params
from anthropic.types.messages import MessageBatch, MessageBatchIndividualResponse, batch_create_params
from google.genai import batches as gbatches
from google.genai import client as gclient
from google.genai import types as gtypes
from openai.types import Batch, BatchError, FileObject, batch_create_params as openai_batch_params
from openai.types import file_create_params
from openai.types.chat import ChatCompletion, completion_create_params

from shapes import finish, gemini_request, model, problems, read_input, typed_dict


def literal_values(td, field):
    hint = typing.get_type_hints(td)[field]
    while typing.get_origin(hint) is not typing.Literal:
        hint = typing.get_args(hint)[0]
    return typing.get_args(hint)


data = read_input()

# OpenAI Batch: the uploaded JSONL (purpose `batch`), its lines, the create params, the replies.
o = data["openai"]
endpoints = literal_values(openai_batch_params.BatchCreateParams, "endpoint")
purposes = literal_values(file_create_params.FileCreateParams, "purpose")
for i, sent in enumerate(o["sent"]):
    where = f"openai sent {i}"
    if "create" in sent:
        typed_dict("batch create", openai_batch_params.BatchCreateParams, sent["create"], where)
        continue
    if sent["purpose"] not in purposes:
        problems.append(f"{where}: purpose `{sent['purpose']}` is not one of {purposes}")
    for j, line in enumerate(sent["lines"]):
        w = f"{where} line {j + 1}"
        if set(line) != {"custom_id", "method", "url", "body"}:
            problems.append(f"{w}: fields {sorted(line)} are not custom_id, method, url, body")
        if line.get("method") != "POST" or line.get("url") not in endpoints:
            problems.append(f"{w}: `{line.get('method')} {line.get('url')}` is no batch endpoint")
        typed_dict("Chat Completions", completion_create_params.CompletionCreateParamsNonStreaming, line["body"], w)
for i, v in enumerate(o["served"]):
    where = f"openai served {i}"
    if v.get("object") == "batch":
        model(Batch, v, where)
    elif v.get("object") == "file":
        model(FileObject, v, where)
    elif "custom_id" in v:
        if v.get("error") is not None:
            model(BatchError, v["error"], where)
        elif v["response"]["status_code"] == 200:
            model(ChatCompletion, v["response"]["body"], where)
    else:
        problems.append(f"{where}: unknown reply {v}")

# Anthropic Message Batches: the create body, the batch objects, the result lines.
a = data["anthropic"]
for i, body in enumerate(a["sent"]):
    typed_dict("Message Batches create", batch_create_params.BatchCreateParams, body, f"anthropic sent {i}")
    for j, r in enumerate(body["requests"]):
        typed_dict("batch request", batch_create_params.Request, r, f"anthropic sent {i} request {j}")
        typed_dict(
            "Messages", message_create_params.MessageCreateParamsNonStreaming, r["params"], f"anthropic sent {i} request {j}"
        )
for i, v in enumerate(a["served"]):
    where = f"anthropic served {i}"
    if v.get("type") == "message_batch":
        model(MessageBatch, v, where)
    else:
        r = model(MessageBatchIndividualResponse, v, where)
        if r is not None and r.result.type == "succeeded":
            model(Message, v["result"]["message"], where)

# Gemini batch mode: the create body has the shape the SDK's own converter gives inline
# requests, each request a Content list and a GenerationConfig; the batch replies read as the
# SDK's BatchJob, each inline response as a GenerateContentResponse.
g = data["gemini"]
sdk = gclient.Client(api_key="x")._api_client
reference = gbatches._CreateBatchJobParameters_to_mldev(
    sdk,
    {"model": "gemini-3-flash-preview", "src": [{"contents": [{"role": "user", "parts": [{"text": "q"}]}], "metadata": {"key": "k"}}],
     "config": {"display_name": "revelio"}},
)
reference.pop("_url", None)


def skeleton(v, depth=0):
    """The keys of a body down to the inline requests (their contents are checked apart)."""
    if isinstance(v, dict) and depth < 4:
        return {k: skeleton(x, depth + 1) for k, x in v.items()}
    if isinstance(v, list):
        return ["list"]
    return "value"


for i, body in enumerate(g["sent"]):
    where = f"gemini sent {i}"
    if skeleton(body) != skeleton(reference):
        problems.append(f"{where}: shape {skeleton(body)} is not the SDK's {skeleton(reference)}")
    for j, item in enumerate(body["batch"]["inputConfig"]["requests"]["requests"]):
        w = f"{where} request {j}"
        if set(item) - {"request", "metadata"}:
            problems.append(f"{w}: unexpected fields {sorted(set(item) - {'request', 'metadata'})}")
        gemini_request(item["request"], w, "request field")
for i, v in enumerate(g["served"]):
    where = f"gemini served {i}"
    job = model(gtypes.BatchJob, gbatches._BatchJob_from_mldev(v), where)
    if job is None:
        continue
    if job.state is None or not str(job.state.value).startswith("JOB_STATE_"):
        problems.append(f"{where}: state `{v['metadata'].get('state')}` is not a batch state the SDK knows")
    for j, r in enumerate(((v["metadata"].get("output") or {}).get("inlinedResponses") or {}).get("inlinedResponses", [])):
        if "response" in r:
            model(gtypes.GenerateContentResponse, r["response"], f"{where} response {j}")
    if v["metadata"].get("output") and not (job.dest and job.dest.inlined_responses):
        problems.append(f"{where}: the SDK finds no inline responses in the output")

finish()
