"""Every relative link and image in the repository's Markdown resolves.

Finds each Markdown file (README.md, docs/, plugin/, fuzz/, blender_addon/, bench/, lab/, ...;
never target/, .venv/ or .git/) and checks every inline link ``[text](path)``, image
``![alt](path)`` and reference definition ``[label]: path`` whose target is not a URL (http:,
https:, mailto: or any other scheme) or a pure ``#anchor``: the path, relative to the Markdown
file (or to the repository root when it starts with ``/``), must be an existing file or folder,
and for ``FILE.md#anchor`` the anchor must be the GitHub slug of one of FILE.md's headings.
Links inside fenced code blocks and inline code spans are not links. Plain pytest and pathlib:
nothing of the project is imported.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from urllib.parse import unquote

REPO = Path(__file__).resolve().parents[2]
SKIPPED_DIRS = {"target", ".venv", ".git"}

FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
ATX_HEADING = re.compile(r"^ {0,3}(#{1,6})(?:[ \t]+(.*?))?(?:[ \t]+#+)?[ \t]*$")
SETEXT_UNDERLINE = re.compile(r"^ {0,3}(=+|-+)[ \t]*$")
# [text](target "title") and ![alt](target): the text may hold one level of brackets and run
# over line breaks (a long alt text); the target may be wrapped in <...>.
INLINE_LINK = re.compile(
    r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]"
    r"\(\s*(?:<([^<>\n]*)>|([^\s()<>]*(?:\([^\s()]*\)[^\s()<>]*)*))"
    r"(?:\s+(?:\"[^\"]*\"|'[^']*'|\([^()]*\)))?\s*\)"
)
REFERENCE_DEFINITION = re.compile(r"^ {0,3}\[[^\]]+\]:[ \t]*<?([^\s>]+)>?", re.MULTILINE)
SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")
HTML_ANCHOR = re.compile(r"""<a\s[^>]*(?:name|id)\s*=\s*["']([^"']+)["']""", re.IGNORECASE)


def markdown_files() -> list[Path]:
    """Every Markdown file under the repository, skipping build outputs, the venv and git."""
    found = []
    for root, dirs, files in os.walk(REPO):
        dirs[:] = sorted(d for d in dirs if d not in SKIPPED_DIRS)
        found.extend(Path(root) / f for f in sorted(files) if f.lower().endswith(".md"))
    return found


def without_code(text: str) -> str:
    """The text with fenced code blocks and inline code spans blanked out (newlines kept, so
    offsets and line numbers stay those of the file)."""
    lines = text.split("\n")
    fence: str | None = None
    for i, line in enumerate(lines):
        match = FENCE.match(line)
        if fence is None:
            if match:
                fence = match.group(1)
                lines[i] = ""
        else:
            if match and match.group(1)[0] == fence[0] and len(match.group(1)) >= len(fence):
                if line.strip() == match.group(1):
                    fence = None
            lines[i] = ""
    return blank_code_spans("\n".join(lines))


def blank_code_spans(text: str) -> str:
    """Inline code spans (a run of n backticks up to the next run of exactly n, within one
    paragraph) replaced by spaces; an unmatched run stays literal."""
    out = list(text)
    runs = [(m.start(), m.end()) for m in re.finditer(r"`+", text)]
    i = 0
    while i < len(runs):
        start, end = runs[i]
        width = end - start
        for j in range(i + 1, len(runs)):
            close_start, close_end = runs[j]
            if "\n\n" in text[end:close_start]:
                break
            if close_end - close_start == width:
                for k in range(start, close_end):
                    if out[k] != "\n":
                        out[k] = " "
                i = j
                break
        i += 1
    return "".join(out)


def heading_text(raw: str) -> str:
    """A heading's text as GitHub renders it before making its slug: links become their text,
    code spans their content, HTML tags go."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", raw)
    text = re.sub(r"<[^>]+>", "", text)
    return text.replace("`", "")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lowercase, punctuation dropped except hyphens and
    underscores, each space a hyphen."""
    text = heading_text(heading).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """The anchors of a Markdown file: its headings' slugs (repeats numbered -1, -2, ... as
    GitHub does) and any HTML ``<a name=...>`` or ``id=...``."""
    text = path.read_text(encoding="utf-8")
    code_free = without_code(text).split("\n")
    lines = text.split("\n")
    seen: dict[str, int] = {}
    found = set(HTML_ANCHOR.findall(text))
    for i, line in enumerate(code_free):
        heading = None
        if ATX_HEADING.match(line):  # outside code; the text with its code spans
            match = ATX_HEADING.match(lines[i])
            heading = (match.group(2) or "") if match else ""
        elif (
            i > 0
            and SETEXT_UNDERLINE.match(line)
            and code_free[i - 1].strip()
            and not code_free[i - 1].lstrip().startswith(("|", "-", "*", ">"))
        ):
            heading = lines[i - 1].strip()
        if heading is None:
            continue
        base = slug(heading)
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def links(path: Path) -> list[tuple[int, str]]:
    """(line, target) of every inline link, image and reference definition outside code."""
    text = without_code(path.read_text(encoding="utf-8"))
    found = []
    for match in INLINE_LINK.finditer(text):
        target = match.group(1) if match.group(1) is not None else match.group(2)
        found.append((text.count("\n", 0, match.start()) + 1, target))
    for match in REFERENCE_DEFINITION.finditer(text):
        found.append((text.count("\n", 0, match.start()) + 1, match.group(1)))
    return found


def problem(source: Path, target: str, anchor_cache: dict[Path, set[str]]) -> str | None:
    """Why a link from `source` to `target` does not resolve, or None if it does (or is not a
    relative link)."""
    if not target or target.startswith("#") or SCHEME.match(target):
        return None
    path_part, _, anchor = target.partition("#")
    path_part = unquote(path_part.split("?", 1)[0])
    base = REPO if path_part.startswith("/") else source.parent
    resolved = (base / path_part.lstrip("/")).resolve()
    if not resolved.exists():
        return "no such file or folder"
    if anchor and resolved.is_file() and resolved.suffix.lower() == ".md":
        if resolved not in anchor_cache:
            anchor_cache[resolved] = anchors(resolved)
        if unquote(anchor).lower() not in anchor_cache[resolved]:
            return f"no heading with anchor #{anchor} in {resolved.relative_to(REPO)}"
    return None


def test_the_markdown_files_are_found():
    files = {p.relative_to(REPO).as_posix() for p in markdown_files()}
    assert "README.md" in files
    assert any(f.startswith("docs/") for f in files), sorted(files)
    assert not any(f.split("/")[0] in SKIPPED_DIRS for f in files)


def test_github_slugs():
    assert slug("Half-angle slicing") == "half-angle-slicing"
    assert slug("The method registry (`occlux methods`)") == "the-method-registry-occlux-methods"
    assert slug('Multiple scattering (`scattering = "multiple"`)') == (
        "multiple-scattering-scattering--multiple"
    )
    assert slug("Where it computes (`--device`), and other options") == (
        "where-it-computes---device-and-other-options"
    )
    assert slug("Python and [Blender](blender.md)") == "python-and-blender"
    assert slug("ao_method and Sundén") == "ao_method-and-sundén"


def test_links_ignore_code_and_span_lines(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "# Title\n\n![a long\nalt text](img.png) and `[not](a-link)`\n\n"
        "```sh\n[also not](a-link)\n```\n[ref]: other.md#title\n",
        encoding="utf-8",
    )
    assert links(page) == [(3, "img.png"), (9, "other.md#title")]
    assert anchors(page) == {"title"}
    page.write_text("# What `occlux ao` writes\n\n## Notes\n\n## Notes\n", encoding="utf-8")
    assert anchors(page) == {"what-occlux-ao-writes", "notes", "notes-1"}


def test_every_relative_link_resolves():
    anchor_cache: dict[Path, set[str]] = {}
    failures = []
    for source in markdown_files():
        for line, target in links(source):
            why = problem(source, target, anchor_cache)
            if why:
                failures.append(f"{source.relative_to(REPO)}:{line}: ({target}) {why}")
    assert not failures, "broken links:\n" + "\n".join(failures)
