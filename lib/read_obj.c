/* placeholder: being written */
typedef int phks_placeholder_read_obj;
