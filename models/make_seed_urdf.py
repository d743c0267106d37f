"""Regenerate models/gc_ocp_seed_subject.urdf (689 N, 1.70 m): python models/make_seed_urdf.py"""

from gc_ocp.model.urdf import write_seed_urdf

if __name__ == "__main__":
    print(write_seed_urdf())
