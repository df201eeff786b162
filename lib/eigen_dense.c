/* placeholder: being written */
typedef int phks_placeholder_eigen_dense;
