"""Reads a Rerun recording with Rerun's own Python reader (rerun-sdk, not the Rust code that wrote it) and
prints what the viewer test checks, as JSON: per entity its rows and `sequence` values, the rope's
points at each sequence (and a bundle's `bundle_sequence` values), the held points' labels at each sequence, the text-log lines, the scalars and
the instruments' shapes (capsules' translations, lengths, quaternions, radii; spheres' centres and
half sizes) and the pulls' arrows (vectors, origins); of static entities (a chain's tissue) their
centres and half sizes, under `static`.

Usage: read_rrd.py FILE.rrd
"""

import json
import sys

from rerun.experimental import RrdReader


def column(batch, suffix):
    """The column named `suffix`, else the one whose name ends with it (names carry the archetype, e.g.
    'LineStrips3D:strips')."""
    if suffix in batch.schema.names:
        return batch.column(suffix).to_pylist()
    for name in batch.schema.names:
        if name.endswith(suffix):
            return batch.column(name).to_pylist()
    return None


def main():
    entities = {}
    for chunk in RrdReader(sys.argv[1]).stream():
        batch = chunk.to_record_batch()
        if chunk.is_static:
            e = entities.setdefault(chunk.entity_path, {"rows": 0, "sequences": [], "values": {}})
            for suffix in (":centers", ":half_sizes"):
                values = column(batch, suffix)
                if values is not None:
                    e.setdefault("static", {})[suffix[1:]] = values
            continue
        seqs = column(batch, "sequence")
        if seqs is None:
            continue
        e = entities.setdefault(
            chunk.entity_path, {"rows": 0, "sequences": [], "values": {}}
        )
        e["rows"] += chunk.num_rows
        e["sequences"] += seqs
        # A bundle's own count of changes (its timeline `bundle_sequence`), where logged.
        bundle_seqs = column(batch, "bundle_sequence")
        if bundle_seqs is not None:
            e.setdefault("bundle_sequences", []).extend(bundle_seqs)
        for suffix in (":strips", ":positions", ":labels", ":text", ":scalars", ":translations",
                       ":lengths", ":quaternions", ":centers", ":half_sizes", ":radii", ":vectors",
                       ":origins"):
            values = column(batch, suffix)
            if values is None:
                continue
            for s, v in zip(seqs, values):
                if v is not None:
                    e["values"].setdefault(suffix[1:], []).append([s, v])
    json.dump(entities, sys.stdout)


if __name__ == "__main__":
    main()
