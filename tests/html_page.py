"""An HTML page read the way a test looks at it: the text of every element with an id, the rows of
every table by table id, every attribute value, and how many embedded PNG images it shows."""

from __future__ import annotations

from html.parser import HTMLParser

VOID = ("br", "img", "meta", "link", "input")


class Page(HTMLParser):
    """Elements by id (their text), table rows by table id, and every attribute value."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.text_by_id: dict[str, list[str]] = {}
        self.rows: dict[str, list[list[str]]] = {}
        self.attrs_seen: list[tuple[str, str, str]] = []
        self.tags: list[str] = []
        self.images = 0  # <img> with an embedded PNG
        self._all: list[str] = []
        self._open: list[tuple[str, str | None]] = []
        self._table: str | None = None
        self._row: list[str] | None = None
        self._cell: list[str] | None = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        self.attrs_seen += [(tag, k, v or "") for k, v in attrs]
        if tag == "img":
            self.images += (a.get("src") or "").startswith("data:image/png;base64,")
        if tag in VOID:
            return
        self._open.append((tag, a.get("id")))
        if a.get("id"):
            self.text_by_id.setdefault(a["id"], [])
        if tag == "table":
            self._table = a.get("id")
            self.rows.setdefault(self._table, [])
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self._row.append(" ".join("".join(self._cell).split()))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.rows[self._table].append(self._row)
            self._row = None
        elif tag == "table":
            self._table = None
        while self._open:
            t, _ = self._open.pop()
            if t == tag:
                break

    def handle_data(self, data):
        self._all.append(data)
        for _, ident in self._open:
            if ident:
                self.text_by_id[ident].append(data)
        if self._cell is not None:
            self._cell.append(data)

    def text(self, ident: str) -> str:
        """The whitespace-normalised text inside the element with id ``ident`` ("" when absent)."""
        return " ".join(" ".join(self.text_by_id.get(ident, [])).split())

    @property
    def all_text(self) -> str:
        """The whole page's text, whitespace-normalised."""
        return " ".join(" ".join(self._all).split())
