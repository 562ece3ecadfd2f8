"""Everything synthetic in dempath: the twin rig, rendered board and field recordings, twins."""
