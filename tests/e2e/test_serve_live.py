"""A live board on `drboard serve`: the event stream of a board's changes, the 304 path, and a
stream that outlives neither its client nor the server."""

from __future__ import annotations

import http.client
import json
import urllib.error
import urllib.request
from urllib.parse import urlsplit

import pytest

from tests.e2e.test_serve import EXAMPLES, Served

BOARD = "reInvent2019_track"


class EventStream:
    def __init__(self, url: str, path: str) -> None:
        parts = urlsplit(url)
        self.connection = http.client.HTTPConnection(parts.hostname or "", parts.port, timeout=10)
        self.connection.request("GET", path)
        self.response = self.connection.getresponse()

    def next_event(self) -> tuple[str, str]:
        """The next event about the board (the stream's keep-alive pings are passed over)."""
        fields: dict[str, str] = {}
        while True:
            line = self.response.readline().decode().rstrip("\n")
            if not line:
                if fields.get("event", "ping") != "ping":
                    return fields["event"], fields.get("data", "")
                fields = {}
                continue
            if line.startswith(":"):
                continue
            name, _, value = line.partition(": ")
            fields[name] = value

    def close(self) -> None:
        self.connection.close()


def test_the_event_stream_tells_each_change_of_the_standings(served: Served) -> None:
    stream = EventStream(served.url, f"/boards/{BOARD}/events")
    try:
        assert stream.response.status == 200
        assert stream.response.getheader("Content-Type") == "text/event-stream"
        assert stream.next_event() == ("board", "missing")
        served.drboard("push", EXAMPLES[0])
        event, first = stream.next_event()
        assert event == "board" and first.endswith(".OPEN")
        served.drboard("push", EXAMPLES[1])
        event, second = stream.next_event()
        assert second != first
        assert int(second.split(".")[0]) > int(first.split(".")[0])
    finally:
        stream.close()


def test_the_page_and_the_api_answer_304_while_nothing_changes(served: Served) -> None:
    served.drboard("push", EXAMPLES[0])
    for path in (f"/boards/{BOARD}", f"/boards/{BOARD}/view"):
        with urllib.request.urlopen(served.url + path) as first:
            etag = first.headers["ETag"]
        request = urllib.request.Request(served.url + path, headers={"If-None-Match": etag})
        with pytest.raises(urllib.error.HTTPError) as unchanged:
            urllib.request.urlopen(request)
        assert unchanged.value.code == 304


def test_serve_stops_with_streams_open(served: Served) -> None:
    streams = [EventStream(served.url, f"/boards/{BOARD}/events") for _ in range(3)]
    for stream in streams:
        assert stream.next_event()[0] == "board"
    assert served.stop() == 0
    for stream in streams:
        stream.close()


def test_a_page_opened_before_the_first_push_shows_the_board_after_it(served: Served) -> None:
    with pytest.raises(urllib.error.HTTPError) as waiting:
        urllib.request.urlopen(f"{served.url}/boards/{BOARD}/view")
    assert waiting.value.code == 404
    assert 'data-missing="1"' in waiting.value.read().decode()
    served.drboard("push", EXAMPLES[0])
    with urllib.request.urlopen(f"{served.url}/boards/{BOARD}/view") as page:
        assert "data-racer=" in page.read().decode()
    listed = json.loads(served.drboard("boards", "--format", "json").stdout)
    assert [b["board_id"] for b in listed] == [BOARD]
