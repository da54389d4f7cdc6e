"""Checks every relative link in the built book (target/book): each href or
src that is not http(s), mailto or a pure fragment must name a file that
exists, and a fragment on a page of the book must name an id on it.
Usage: python3 scripts/book_links.py BOOK_DIR  (exit 1 and a list if any
is broken). Run by scripts/docs.sh, which CI runs."""
import html.parser
import os
import sys
import urllib.parse


class Links(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.links, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        for k, v in attrs:
            if k == "id" and v:
                self.ids.add(v)
            if k in ("href", "src") and v:
                self.links.append(v)


def parse(path):
    p = Links()
    with open(path, encoding="utf-8") as f:
        p.feed(f.read())
    return p


def main(book):
    pages = {}
    for root, _, files in os.walk(book):
        for name in files:
            if name.endswith(".html"):
                path = os.path.join(root, name)
                pages[os.path.normpath(path)] = parse(path)
    broken, checked = [], 0
    for page, p in sorted(pages.items()):
        for link in p.links:
            u = urllib.parse.urlsplit(link)
            if u.scheme or link.startswith("//") or link.startswith("#") and not link[1:]:
                continue
            target = os.path.normpath(os.path.join(os.path.dirname(page), urllib.parse.unquote(u.path))) if u.path else page
            checked += 1
            if not os.path.exists(target):
                broken.append(f"{os.path.relpath(page, book)}: {link} (no {os.path.relpath(target, book)})")
            elif u.fragment and target in pages and u.fragment not in pages[target].ids:
                broken.append(f"{os.path.relpath(page, book)}: {link} (no id {u.fragment!r})")
    if broken:
        print(f"book_links: {len(broken)} broken of {checked} relative links:", *broken, sep="\n  ")
        return 1
    print(f"book_links: {checked} relative links in {len(pages)} pages, none broken")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "target/book"))
