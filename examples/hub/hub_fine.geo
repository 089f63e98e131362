// hub.geo at half the element size (0.5 mm, 0.25 mm on the interface): the mesh the twin data are made on.
h = 0.5;
Include "hub.geo";
