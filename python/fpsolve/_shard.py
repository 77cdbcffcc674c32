"""One part of a split run as the command line's shard file holds it."""

from __future__ import annotations

import json


class ShardText:
    """A shard file's text with the part it is: ``index`` (from 0) of ``count``. Pickles by
    its text."""

    __slots__ = ("json", "index", "count")

    def __init__(self, text: str):
        self.json = text
        shard = json.loads(text)["shard"]
        self.index = int(shard["index"])
        self.count = int(shard["count"])

    def __reduce__(self):
        return (type(self), (self.json,))
