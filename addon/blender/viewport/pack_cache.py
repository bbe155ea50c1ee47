"""What the viewport builds from an item's arrays, cached by their identity, the keys it is
filed under, and the upload of a texture joined from them when they change (no bpy; the
gpu object is handed in)."""
from __future__ import annotations

from ...core.scene import RenderItem
from . import packing
from .effect_rows import mover_of


class PackCache:
    """Packed arrays per object and texture, cached by the identity of their sources.

    A hit needs the same item key and the very same source arrays (`is`): effects may
    change opacities under an unchanged key, and the draw handler hands back the same
    arrays while an object's data is unchanged. Entries hold their sources, so an id
    can never be recycled while cached. Only the current frame's entries are kept.
    """

    def __init__(self):
        self.entries: dict = {}
        self.used: dict = {}
        self.built = 0  # arrays packed so far

    def get(self, name: str, item: RenderItem, sources: tuple, build, extra=(), key=None):
        """key: the item key to file the entry under (default item.key)."""
        ident = (name, item.key if key is None else key, tuple(id(a) for a in sources), extra)
        hit = self.entries.get(ident)
        if hit is None or any(x is not y for x, y in zip(hit[0], sources)):
            hit = (sources, build())
            self.built += 1
        self.used[ident] = hit
        return ident, hit[1]

    def end_frame(self) -> int:
        """Drop entries not used this frame; returns the bytes kept."""
        self.entries, self.used = self.used, {}
        return sum(v[1].nbytes for v in self.entries.values())


def positions_key_of(item: RenderItem):
    return data_key(item, ("positions",)) if item.positions_key is None else item.positions_key


def reads_rest(item: RenderItem) -> bool:
    """Whether a deferred effect of the item measures centres other than those of its pos
    texture (where the preprocess pass moves the centres, that holds the ones they start
    from: pos_source; for a displace, the rest centres)."""
    return (item.rest_positions is not None and item.rest_positions is not item.splats.positions
            and mover_of(item.deferred) is None and any(d.at_rest for d in item.deferred))


def pos_source(item: RenderItem) -> tuple:
    """(key, centres) of the pos texture: the drawn centres, or where the preprocess pass
    moves them (a deferred displace or morph), those it moves them from (the stack's input,
    or a morph's source end: the same array from frame to frame while scrubbing, so
    uploaded once)."""
    mover = mover_of(item.deferred)
    if mover is None:
        return positions_key_of(item), item.splats.positions
    return ("moved from", item.base_key), mover.centres


def data_key(item: RenderItem, fields: tuple):
    """The key to file what is built from these SplatSet fields under: the base data's
    version while they are all its own arrays (an effect playing changes item.key every
    frame but leaves them alone), else the item's key."""
    if item.base_key is not None and item.base_fields.issuperset(fields):
        return item.base_key
    return item.key


def upload_if_new(tokens: dict, gpu, name: str, got: list, flat) -> bool:
    """Upload texture `name` from flat() unless `got` (PackCache.get's results, an object
    each) is what it was last built from (tokens: name -> their identities). Returns
    whether it uploaded."""
    token = tuple(ident for ident, _ in got)
    if tokens.get(name) == token:
        return False
    gpu.set_texture(name, flat())
    tokens[name] = token
    return True


def joined(got: list, counts: list, per_splat: int):
    """The objects' packed streams (PackCache.get's results) as one stream, in order."""
    return got[0][1] if len(got) == 1 else packing.concatenate([a for _, a in got], counts, per_splat)


def shared_data(items) -> tuple[list, list]:
    """(index of each distinct data's first item, each item's slot in that list). Instances
    of one object share its item's arrays (evaluate.items.placed): their data is packed and
    uploaded once, and each instance draws it through its own object row."""
    firsts, slots, seen = [], [], {}
    for k, item in enumerate(items):
        ident = (item.key, id(item.splats), tuple(map(id, item.deferred)), id(item.rest_positions))
        if item.key is None:
            ident = (k,)  # uncached: its own data
        if ident not in seen:
            seen[ident] = len(firsts)
            firsts.append(k)
        slots.append(seen[ident])
    return firsts, slots


def data_firsts(items, slots) -> list:
    """Each distinct data's first splat in the data textures."""
    counts = {}
    for item, slot in zip(items, slots):
        counts.setdefault(slot, item.splats.count)
    out, start = [], 0
    for slot in range(len(counts)):
        out.append(start)
        start += counts[slot]
    return out
