"""The small plane-strain case several end-to-end tests fit (test_identify, test_parallel, test_html_report): the
3-zone block2d model at 1 mm, six uy/ux observation points on the block's sides and the base top, its true
coefficients, and the [model] / regions lines of its configs."""

#: the coefficients the twin data are simulated with
TRUE = {"A": 0.32, "B": 0.18, "C": 0.41}
#: a measurement file template (values are placeholders; `frictionid simulate` fills them)
POINTS = """# observation points on the block's sides and the base top (plane strain, z = 0)
point,x,y,z,stage,uy
P1,-5.0,0.5,0.0,1,0.0
P2,-5.0,1.5,0.0,1,0.0
P3,5.0,0.5,0.0,1,0.0
P4,5.0,1.5,0.0,1,0.0
P5,-7.0,0.0,0.0,1,0.0
P6,7.0,0.0,0.0,1,0.0
"""
MODEL = '[model]\nbuilder = "block2d"\nmesh_size = 1.0\nheight = 4.0\nn_zones = 3\n'
#: the [data] regions line: P1-P4 on the block, P5, P6 on the base
REGIONS = 'regions = { P1 = "block", P2 = "block", P3 = "block", P4 = "block", P5 = "base", P6 = "base" }\n'
