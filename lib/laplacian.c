/* placeholder: being written */
typedef int phks_placeholder_laplacian;
