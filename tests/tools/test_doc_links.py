"""Every relative link in README.md and docs/*.md points at a file that exists and, with a
#fragment, at a heading of that file (GitHub's anchors: lower case, punctuation dropped, spaces as
hyphens)."""
import os
import re
import unittest

from tools_test_util import ROOT

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")


def anchors(path):
    """The GitHub anchors of a markdown file's headings (outside code blocks)."""
    seen = {}
    out = set()
    fence = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.lstrip().startswith("```"):
                fence = not fence
                continue
            m = None if fence else HEADING.match(line)
            if not m:
                continue
            text = re.sub(r"[`*]|\[([^\]]*)\]\([^)]*\)", lambda g: g.group(1) or "", m.group(1))
            slug = re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def links(path):
    fence = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if line.lstrip().startswith("```"):
                fence = not fence
                continue
            if not fence:
                for target in LINK.findall(line):
                    yield number, target


class DocLinksTest(unittest.TestCase):
    def test_every_relative_link_resolves(self):
        pages = [os.path.join(ROOT, "README.md")]
        docs = os.path.join(ROOT, "docs")
        pages += [os.path.join(docs, p) for p in sorted(os.listdir(docs)) if p.endswith(".md")]
        bad = []
        for page in pages:
            for number, target in links(page):
                if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                    continue
                file_part, _, fragment = target.partition("#")
                path = os.path.normpath(os.path.join(os.path.dirname(page), file_part)) \
                    if file_part else page
                where = f"{os.path.relpath(page, ROOT)}:{number}: {target}"
                if not os.path.exists(path):
                    bad.append(f"{where} (no such file)")
                elif fragment and path.endswith(".md") and fragment not in anchors(path):
                    bad.append(f"{where} (no such heading)")
        self.assertEqual(bad, [])


if __name__ == "__main__":
    unittest.main()
