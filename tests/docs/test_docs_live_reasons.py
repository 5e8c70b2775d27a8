"""docs/live-sessions.md quotes a bad request's reason as a client reads it, and
docs/operator.md gives ``GeneratorHandler.handle``'s keywords as the code has them."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest
from oimi.pipeline.operator.handler import GeneratorHandler

from oimi.live.protocol import ProtocolError, decode_request

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_the_bad_request_reason_is_the_one_a_client_reads() -> None:
    text = (DOCS / "live-sessions.md").read_text()
    (quoted,) = re.findall(r"``(bad request: .*?) ``", text)
    with pytest.raises(ProtocolError) as refused:
        decode_request('{"id": 3, "cmd": "reorder", "activity": "greeting", "position": "x"}')
    assert str(refused.value) == quoted


def test_the_handlers_signature_names_every_keyword() -> None:
    text = (DOCS / "operator.md").read_text()
    (line,) = re.findall(r"`handle\((.*?)\) ->", text)
    documented = [p.split("=")[0].split(":")[0].strip() for p in line.split(",")]
    parameters = inspect.signature(GeneratorHandler.handle).parameters
    assert [d for d in documented if d != "*"] == [p for p in parameters if p != "self"]
