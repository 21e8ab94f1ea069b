# pflow_add_proto_library(NAME target ROOT dir PROTOS files...): protoc + grpc_cpp_plugin -> one static library with
# the messages and the service stubs, include root = the build folder's generated dir.
find_package(Protobuf REQUIRED)
find_package(gRPC CONFIG REQUIRED)
find_program(PFLOW_GRPC_CPP_PLUGIN grpc_cpp_plugin REQUIRED)

function(pflow_add_proto_library)
  cmake_parse_arguments(P "" "NAME;ROOT" "PROTOS" ${ARGN})
  set(out ${CMAKE_CURRENT_BINARY_DIR}/generated)
  file(MAKE_DIRECTORY ${out})
  set(sources)
  foreach(proto ${P_PROTOS})
    file(RELATIVE_PATH rel ${P_ROOT} ${proto})
    string(REGEX REPLACE "\\.proto$" "" stem ${rel})
    set(gen ${out}/${stem}.pb.cc ${out}/${stem}.pb.h ${out}/${stem}.grpc.pb.cc ${out}/${stem}.grpc.pb.h)
    add_custom_command(
      OUTPUT ${gen}
      COMMAND protobuf::protoc --proto_path=${P_ROOT} --cpp_out=${out} --grpc_out=${out}
              --plugin=protoc-gen-grpc=${PFLOW_GRPC_CPP_PLUGIN} ${proto}
      DEPENDS ${proto} protobuf::protoc
      COMMENT "protoc ${rel}"
      VERBATIM)
    list(APPEND sources ${out}/${stem}.pb.cc ${out}/${stem}.grpc.pb.cc)
  endforeach()
  add_library(${P_NAME} STATIC ${sources})
  target_include_directories(${P_NAME} PUBLIC ${out})
  target_link_libraries(${P_NAME} PUBLIC protobuf::libprotobuf gRPC::grpc++)
  # Generated code is not ours to warn about.
  target_compile_options(${P_NAME} PRIVATE -w)
endfunction()
