"""The consistency check of a published output folder (what the publication tests assert)."""

import json
from pathlib import Path

from tableclean_suite.bench.outputs import MANIFEST, sha256_file


def check_outputs(out) -> list[str]:
    """Problems of an output directory (a missing ``config.json`` is one); ``[]`` when ``config.json`` and its
    data files agree and no other file (hidden ones, folders and ``kept`` aside) lies beside them."""
    out = Path(out)
    try:
        document = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return [f"{out / MANIFEST} is missing: the last run did not finish writing its outputs"]
    except (OSError, ValueError) as error:
        return [f"{out / MANIFEST} is unreadable: {error}"]
    files = document.get("files")
    if not isinstance(files, dict) or "run_id" not in document:
        return [f"{out / MANIFEST} has no run_id or files list (written by an older version?)"]
    problems = []
    for name, facts in files.items():
        path = out / name
        if not path.is_file():
            problems.append(f"{path} is missing")
        elif sha256_file(path) != facts.get("sha256"):
            problems.append(f"{path} is not the file of run {document['run_id']} (SHA-256 differs)")
    listed = {MANIFEST, *files, *document.get("kept", ())}
    problems += [f"{path} is not listed in {MANIFEST}: not a file of run {document['run_id']}"
                 for path in sorted(out.iterdir()) if path.is_file() and path.name not in listed
                 and not path.name.startswith(".")]
    return problems
