"""Machine definitions and kinematics (leaf package: imports nothing of ours).

Will own: axis and machine definitions shipped as TOML data, loaded by name or path;
vectorized forward and inverse kinematics for 3-axis and 5-axis (table-table, head-table)
machines with branch choice, rotary unwrap and the singular cone; travel and rate limit
checks that report violations rather than clip.
"""
