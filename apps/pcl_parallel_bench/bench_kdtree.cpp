namespace pcl_parallel{namespace bench{struct Options; int runKdTree(const Options&){return 0;}}}
