/* placeholder: being written */
typedef int phks_placeholder_signature_codec;
