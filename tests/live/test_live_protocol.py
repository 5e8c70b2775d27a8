"""The App Interface's messages: strict decoding, size limit, replies as JSON lines."""

from __future__ import annotations

from typing import get_args

import pytest
from oimi.pipeline.operator.commands import VERBS, Add, OperatorCommand, Reorder

from oimi.live.protocol import (
    MAX_LINE_BYTES,
    ProtocolError,
    Reply,
    Subscribe,
    decode_request,
    encode_message,
)


def test_requests_decode_by_their_cmd():
    assert decode_request(
        '{"id": 4, "cmd": "add", "activity": "test_dance", "options": {"tempo": "fast"}}'
    ) == Add(id=4, activity="test_dance", options={"tempo": "fast"})
    assert decode_request(b'{"cmd": "reorder", "activity": "a", "position": 2}') == Reorder(
        activity="a", position=2
    )
    assert decode_request('{"cmd": "subscribe", "world": true}') == Subscribe(world=True)


@pytest.mark.parametrize(
    ("line", "match", "request_id"),
    [
        ("{oops", "malformed JSON", None),
        ('{"id": 3, "cmd": "fly"}', r"Invalid value 'fly' - at `\$.cmd`", 3),
        ('{"id": 5, "cmd": "add"}', "missing required field `activity`", 5),
        ('{"id": 6, "cmd": "reorder", "activity": "a", "position": "top"}', r"\$.position", 6),
        (
            '{"id": 8, "cmd": "reorder", "activity": "a", "position": -1}',
            r">= 0 - at `\$.position`",
            8,
        ),
        ('{"id": 9, "cmd": "stop", "activity": "a"}', "unknown field `activity`", 9),
        ('{"id": 7, "cmd": "start", "now": true}', "unknown field `now`", 7),
        ('["start"]', "bad request", None),
    ],
)
def test_bad_requests_are_refused_with_the_reason_and_their_id(line, match, request_id):
    with pytest.raises(ProtocolError, match=match) as caught:
        decode_request(line)
    assert caught.value.id == request_id


def test_oversized_lines_are_refused_before_decoding():
    with pytest.raises(ProtocolError, match="message too long"):
        decode_request(b'{"cmd": "list", "pad": "' + b"x" * MAX_LINE_BYTES + b'"}')


def test_replies_are_one_json_line_without_empty_fields():
    assert encode_message(Reply(id=2, ok=False, reason="busy")) == (
        b'{"type":"reply","id":2,"ok":false,"reason":"busy"}\n'
    )


@pytest.mark.parametrize("verb", VERBS)
def test_the_operators_commands_are_the_pipelines_own(verb):
    """No second shape: the App Interface decodes the union the handler matches on."""
    fields = {"add": ', "activity": "a"', "remove": ', "activity": "a"'}.get(verb, "")
    if verb == "reorder":
        fields = ', "activity": "a", "position": 0'
    request = decode_request(f'{{"id": 3, "cmd": "{verb}"{fields}}}')
    assert isinstance(request, get_args(OperatorCommand)) and request.verb == verb
