/* placeholder: being written */
typedef int phks_placeholder_mesh_load;
