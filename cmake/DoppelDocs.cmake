# The architecture diagrams: docs/*.dot rendered by graphviz into build/docs/*.svg on every build,
# and a test that they render and that the folder graph names every library folder.
find_program(DOPPEL_DOT dot REQUIRED)
file(GLOB doppel_diagram_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/*.dot)
set(doppel_diagrams)
foreach(source ${doppel_diagram_sources})
  get_filename_component(stem ${source} NAME_WE)
  set(svg ${PROJECT_BINARY_DIR}/docs/${stem}.svg)
  add_custom_command(OUTPUT ${svg}
                     COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/docs
                     COMMAND ${DOPPEL_DOT} -Tsvg ${source} -o ${svg}
                     DEPENDS ${source} COMMENT "Rendering docs/${stem}.dot" VERBATIM)
  list(APPEND doppel_diagrams ${svg})
endforeach()
add_custom_target(docs ALL DEPENDS ${doppel_diagrams})
